"""Test helper: robot folders for example-robot-data's quadrupeds, drafted here by hand (not by
`legplan robot init`), pointing at the package's own URDFs, which stay untouched.

Per robot, by hand from its URDF: the leg chains and foot links, the foot sphere's radius (its
URDF collision sphere, or for Solo12's mesh foot its size) with the contact point one radius below
the foot link's origin. From the package and pinocchio: the standing configuration of the
package's SRDF (`group_state name="standing"`), the base height that puts the feet on z = 0, and a
`centroidal:` section (total mass, ccrba inertia about the CoM, the CoM's offset, nominal feet).
The only other spheres are three along the trunk, so a trunk on the terrain is still seen.
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml

# name: (URDF, SRDF, trunk link, trunk half length (m), trunk sphere radius (m), foot radius (m),
#        {leg: ([joints], foot link)})
PUBLISHED = {
    "anymal_b": ("anymal_b_simple_description/robots/anymal.urdf", "anymal_b_simple_description/srdf/anymal.srdf",
                 "base", 0.25, 0.12, 0.031, "{L}_{J}", ("HAA", "HFE", "KFE"), "{L}_FOOT", ("LF", "RF", "LH", "RH")),
    "anymal_c": ("anymal_c_simple_description/urdf/anymal.urdf", "anymal_c_simple_description/srdf/anymal.srdf",
                 "base", 0.25, 0.12, 0.03, "{L}_{J}", ("HAA", "HFE", "KFE"), "{L}_FOOT", ("LF", "RF", "LH", "RH")),
    "hyq": ("hyq_description/robots/hyq_no_sensors.urdf", "hyq_description/srdf/hyq.srdf",
            "trunk", 0.35, 0.12, 0.02175, "{l}_{j}_joint", ("haa", "hfe", "kfe"), "{l}_foot", ("lf", "rf", "lh", "rh")),
    "go1": ("go1_description/urdf/go1.urdf", "go1_description/srdf/go1.srdf",
            "trunk", 0.15, 0.06, 0.02, "{L}_{j}_joint", ("hip", "thigh", "calf"), "{L}_foot", ("FL", "FR", "RL", "RR")),
    "solo12": ("solo_description/robots/solo12.urdf", "solo_description/srdf/solo.srdf",
               "base_link", 0.15, 0.05, 0.016, "{L}_{J}", ("HAA", "HFE", "KFE"), "{L}_FOOT", ("FL", "FR", "HL", "HR")),
}


def robots_dir() -> Path:
    """example-robot-data's robots folder, found through the installed distribution's files."""
    return Path(importlib.metadata.distribution("example-robot-data").locate_file(
        "cmeel.prefix/share/example-robot-data/robots"))


def draft(name: str, folder: Path) -> Path:
    """Write `folder/robot.yaml` for the published robot `name` (module docstring); its path."""
    urdf_rel, srdf_rel, trunk, half, trunk_r, radius, joint_fmt, joints, foot_fmt, legs = PUBLISHED[name]
    urdf, srdf = robots_dir() / urdf_rel, robots_dir() / srdf_rel
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    pin.loadReferenceConfigurations(model, str(srdf), False)
    q = model.referenceConfigurations["standing"].copy()
    q[:7] = [0, 0, 0, 0, 0, 0, 1]
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)

    def fmt(template, leg, joint=""):
        return template.format(L=leg.upper(), l=leg.lower(), J=joint.upper(), j=joint.lower())

    feet_links = [fmt(foot_fmt, leg) for leg in legs]
    feet = np.array([data.oMf[model.getFrameId(link, pin.FrameType.BODY)].act(np.array([0, 0, -radius]))
                     for link in feet_links])
    height = -float(feet[:, 2].mean())
    q[2] = height
    pin.centerOfMass(model, data, q)
    pin.ccrba(model, data, q, np.zeros(model.nv))
    inertia = data.Ig.inertia
    spec = {
        "name": name, "urdf": str(urdf),
        "legs": [{"name": leg.upper(), "joints": [fmt(joint_fmt, leg, j) for j in joints],
                  "foot": {"link": link, "offset": [0.0, 0.0, -radius], "frame": f"{leg.upper()}_contact"}}
                 for leg, link in zip(legs, feet_links)],
        "collision_spheres": [{"link": trunk, "offset": [x, 0.0, 0.0], "radius": trunk_r} for x in (-half, 0.0, half)]
        + [{"link": f"{leg.upper()}_contact", "offset": [0.0, 0.0, 0.0], "radius": radius} for leg in legs],
        "nominal": {"base_height": height,
                    "joints": {leg.upper(): [float(q[model.idx_qs[model.getJointId(fmt(joint_fmt, leg, j))]])
                                             for j in joints] for leg in legs}},
        "centroidal": {
            "mass": float(pin.computeTotalMass(model)),
            "inertia": {"ixx": float(inertia[0, 0]), "iyy": float(inertia[1, 1]), "izz": float(inertia[2, 2]),
                        "ixy": float(inertia[0, 1]), "ixz": float(inertia[0, 2]), "iyz": float(inertia[1, 2])},
            "com_offset": (data.com[0] - [0.0, 0.0, height]).tolist(),
            "nominal_feet": {leg.upper(): [float(v) for v in foot] for leg, foot in zip(legs, feet)},
            "range_of_motion": [0.1 * height, 0.06 * height, 0.06 * height],
            "max_normal_force": float(10 * 9.81 * pin.computeTotalMass(model)),
            "friction": 0.5}}
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "robot.yaml").write_text(yaml.safe_dump(spec, sort_keys=False))
    return folder / "robot.yaml"
