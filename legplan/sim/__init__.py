"""Physics execution of planned motions: MuJoCo model from a robot folder, whole-body tracking controller
(TOWR-costs paper Sec. III-B/C), `simulate(samples, robot, terrain_map, params)`."""
