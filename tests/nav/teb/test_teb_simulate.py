"""Receding-horizon simulation on a small map with a hidden obstacle: reaches the goal, no collisions."""

import numpy as np

from legplan.nav.params import NavParams
from legplan.nav.simulate import Goal, Robot, NavRunParams, World, kinodynamic_planner, run_navigation
from legplan.nav.teb.params import TebParams
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import CostmapParams

RADIUS = 0.4031  # circumscribed radius of the 0.70 m × 0.40 m footprint


def small_world(hidden_box=True):
    grid = Grid2D((0.025, 0.025), 0.05, (100, 120))  # 6 m × 5 m room
    X, Y = grid.centres()
    walls = (X < 0.2) | (X > 5.8) | (Y < 0.2) | (Y > 4.8)
    hidden = (np.abs(X - 3.0) < 0.15) & (np.abs(Y - 2.3) < 0.15) if hidden_box else np.zeros_like(walls)
    return World(grid, walls, hidden, CostmapParams(), RADIUS)


def test_simulation_reaches_goal_around_hidden_obstacle_without_collision(table_i):
    world = small_world()
    # sensing radius 1.5 m: the box is unknown when the global plan is made straight through it
    sim = NavRunParams(sensing_radius=1.5, max_time=40.0)
    result = run_navigation(world, kinodynamic_planner(NavParams()), [1.0, 2.5, 0.0], [Goal((5.0, 2.5))], table_i,
                      TebParams(outer_iterations=2), sim)
    assert result.success, result.reason
    assert result.collisions == 0
    assert result.replans >= 2  # initial plan + a replan once the box is seen
    assert np.hypot(*(result.states[-1, :2] - [5.0, 2.5])) <= sim.goal_tolerance
    # the executed motion respects the robot's limits and passes the box at a distance
    v = result.states[:, 3:]
    assert v[:, 0].max() <= table_i.v_x_max + 1e-9 and np.abs(v[:, 1]).max() <= table_i.v_y_max + 1e-9
    near_box = np.abs(result.states[:, 0] - 3.0) < 0.15
    assert np.all(np.abs(result.states[near_box, 1] - 2.3) > 0.35)
    assert result.effort() > 0 and len(result.compute_seconds) == len(result.commands)


def test_robot_obeys_acceleration_limits_and_nonholonomic_model(table_i):
    robot = Robot([0, 0, 0], table_i, omnidirectional=False)
    robot.step(np.array([1.0, 0.2, 0.0]), 0.1)
    assert np.allclose(robot.velocity, [0.1, 0.0, 0.0])  # a_x max 1.0 m/s² for 0.1 s, no lateral motion
    omni = Robot([0, 0, np.pi / 2], table_i)
    for _ in range(100):
        omni.step(np.array([0.0, 0.5, 0.0]), 0.01)
    assert np.allclose(omni.velocity, [0, 0.17, 0])  # a_y max for 1 s, below v_y max
    assert omni.pose[0] < 0 and abs(omni.pose[1]) < 1e-12  # body +y is world −x at θ = π/2


def test_collision_disc_uses_true_map_and_the_planners_radius():
    world = small_world()
    assert world.in_collision(np.array([3.0, 2.3, 0.0]))  # the hidden box is real
    assert not world.in_collision(np.array([1.0, 1.0, 0.0]))
    # the wall's last cell centre is at x = 0.175: clear beyond 0.175 + 0.4031 m, whatever the yaw
    assert world.in_collision(np.array([0.575, 1.0, np.pi / 2]))
    assert not world.in_collision(np.array([0.58, 1.0, 0.0]))
    assert world.in_collision(np.array([5.9, 4.9, 0.0]))  # the disc leaves the map
    # planning uses the same radius: the known map's lethal cells are those within it
    assert world.nav_grid.l1 == RADIUS
    assert world.nav_grid.lethal_at(np.array([[0.57, 1.0]]))[0]
    assert not world.nav_grid.lethal_at(np.array([[0.6, 1.0]]))[0]


def test_a_run_with_a_collision_is_not_a_success(table_i):
    class Clumsy(World):
        def in_collision(self, pose):
            return pose[0] > 2.0  # a phantom obstacle the planners do not know

    grid = Grid2D((0.025, 0.025), 0.05, (100, 120))
    X, Y = grid.centres()
    walls = (X < 0.2) | (X > 5.8) | (Y < 0.2) | (Y > 4.8)
    world = Clumsy(grid, walls, np.zeros_like(walls), CostmapParams(), RADIUS)
    result = run_navigation(world, kinodynamic_planner(NavParams()), [1.0, 2.5, 0.0], [Goal((3.0, 2.5))],
                      table_i, TebParams(outer_iterations=2), NavRunParams(max_time=30.0))
    assert np.hypot(*(result.states[-1, :2] - [3.0, 2.5])) <= 0.1  # it got there ...
    assert result.collisions > 0 and not result.success  # ... but touched the obstacle
    assert result.reason.startswith(f"reached the goal with {result.collisions} substeps in collision")
