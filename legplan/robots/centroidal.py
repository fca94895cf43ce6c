"""The `centroidal:` section of robot.yaml: the single-rigid-body model of a centroidal planner.

The model of TOWR (Winkler et al. 2018) and of `legplan dyn`: the whole robot as one rigid body of
mass m and inertia I about its CoM, which lies at `com_offset` in the base frame (zero when
absent: TOWR's models put the CoM at the base origin), feet that push with forces bounded by
`max_normal_force` inside a friction pyramid of coefficient `friction`, and a range-of-motion box
(half extents `range_of_motion`) around each foot's nominal position in the base frame. With
`torque_limits` (per leg, one bound per joint in the leg's order, at most the URDF's efforts) the
forces also stay inside each leg's torque polytope |J(q)ᵀ f| ≤ τ_max, J the foot's Jacobian at the
joints q that put it where the plan has it: the forces the joints can give, where one scalar
bound on the normal force ignores the leg's configuration and the force's direction.

```yaml
centroidal:
  mass: 29.5                                  # kg, must equal the URDF's total mass
  inertia: {ixx: .., iyy: .., izz: .., ixy: .., ixz: .., iyz: ..}   # kg m^2, tensor entries
  com_offset: [0.0, 0.0, 0.0]                 # m, the CoM in the base frame (optional, default 0)
  nominal_feet: {lf: [0.34, 0.19, -0.42], ...}   # m, base frame, one per leg, below the base
  range_of_motion: [0.15, 0.10, 0.10]         # m
  max_normal_force: 1000.0                    # N
  friction: 0.5
  torque_limits: {lf: [80, 80, 80], ...}      # N m, optional: per leg, its joints' order
```

The inertia keys are the entries of the symmetric tensor (URDF convention: ixy = I[0, 1] =
-∫xy dm), not the products of inertia some codes pass (TOWR's BuildInertiaTensor negates them).
The tensor must be that of a rigid body: positive definite, principal moments obeying the triangle
inequality. Every error is a one-line `SpecError` naming the file and the field.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from legplan.parameters import FORCE, FRICTION, LENGTH, TORQUE
from legplan.specio import FieldReader

INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
SECTION_KEYS = ("mass", "inertia", "com_offset", "nominal_feet", "range_of_motion", "max_normal_force",
                "friction", "torque_limits")
MASS_TOLERANCE = 1e-6  # relative, centroidal mass vs the URDF's total mass


@dataclass(frozen=True)
class Centroidal:
    """Single-rigid-body parameters (SI units); arrays are read-only.

    `inertia` (3, 3) in the base frame about the CoM; `nominal_feet` (n_legs, 3) in the base frame,
    row k for leg `legs[k]` (robot.yaml order); `range_of_motion` (3,) half extents of the box
    around each nominal foot; `com_offset` (3,) the CoM's position in the base frame."""

    mass: float
    inertia: np.ndarray
    legs: tuple[str, ...]
    nominal_feet: np.ndarray
    range_of_motion: np.ndarray
    max_normal_force: float
    friction: float
    com_offset: np.ndarray = None
    leg_kinematics: object = None
    """The legs' closed-form kinematics (`legplan.robots.planar_legs.PlanarLegs`), set by `RobotModel`
    from the URDF; None for legs of another kind (the planner's leg clearance needs it)."""
    torque_limits: tuple | None = None
    """Per leg (robot.yaml order) its joints' torque bounds (N m, read-only arrays in the leg's joint
    order); None: the forces are bounded by `max_normal_force` and friction alone."""
    leg_chains: object = None
    """The legs' chains (`legplan.dyn.legs.ChainLegs`) the planner's torque polytope places the
    joints by, set by `legplan.dyn.tasks.centroidal_model` when `torque_limits` are given."""

    def __post_init__(self):
        if self.com_offset is None:
            object.__setattr__(self, "com_offset", np.zeros(3))
        for array in (self.inertia, self.nominal_feet, self.range_of_motion, self.com_offset,
                      *(self.torque_limits or ())):
            array.setflags(write=False)

    @property
    def base_height(self) -> float:
        """Nominal height of the base above the feet: minus the mean nominal foot z (m)."""
        return float(-self.nominal_feet[:, 2].mean())


def parse_centroidal(reader: FieldReader, data: dict, legs: tuple[str, ...], urdf_mass: float) -> Centroidal | None:
    """The validated `centroidal` section of the robot.yaml mapping `data`; None when absent."""
    section = reader.get(data, "centroidal", "centroidal", dict, None)
    if section is None:
        return None
    unknown = sorted(set(section) - set(SECTION_KEYS))
    if unknown:
        reader.fail(f"centroidal.{unknown[0]}", f"is unknown (expected {', '.join(SECTION_KEYS)})")
    mass = reader.positive(reader.get(section, "mass", "centroidal.mass"), "centroidal.mass")
    if abs(mass - urdf_mass) > MASS_TOLERANCE * urdf_mass:
        reader.fail("centroidal.mass", f"is {mass:g} kg but the URDF's links sum to {urdf_mass:.6g} kg")
    rom = reader.vector(reader.get(section, "range_of_motion", "centroidal.range_of_motion"),
                        "centroidal.range_of_motion", 3)
    for k, value in enumerate(rom):
        reader.positive(value, f"centroidal.range_of_motion[{k}]", LENGTH)
    offset = section.get("com_offset")
    com_offset = np.zeros(3) if offset is None else reader.vector(offset, "centroidal.com_offset", 3)
    return Centroidal(
        mass=mass, inertia=_inertia(reader, section), legs=tuple(legs), com_offset=com_offset,
        nominal_feet=_nominal_feet(reader, section, legs), range_of_motion=rom,
        max_normal_force=reader.positive(reader.get(section, "max_normal_force", "centroidal.max_normal_force"),
                                         "centroidal.max_normal_force", FORCE),
        friction=reader.positive(reader.get(section, "friction", "centroidal.friction"), "centroidal.friction", FRICTION),
        torque_limits=_torque_limits(reader, section, legs))


def _torque_limits(reader: FieldReader, section: dict, legs: tuple[str, ...]) -> tuple | None:
    """The optional `torque_limits` mapping, one list of positive bounds per leg (lengths against
    the legs' joints: `legplan.robots.spec`)."""
    if section.get("torque_limits") is None:
        return None
    return tuple(np.array([reader.positive(v, f"{field}[{k}]", TORQUE) for k, v in enumerate(values)])
                 for field, values in _per_leg(reader, section, "torque_limits", legs, None))


def _per_leg(reader: FieldReader, section: dict, key: str, legs: tuple[str, ...], length: int | None):
    """(field, vector) of every leg of the per-leg mapping `key`, in the order of `legs`; a leg it
    lacks or a name that is no leg is a `SpecError`."""
    mapping = reader.get(section, key, f"centroidal.{key}", dict)
    unknown = sorted(str(name) for name in set(mapping) - set(legs))
    if unknown:
        reader.fail(f"centroidal.{key}.{unknown[0]}", f"names no leg (legs: {', '.join(legs)})")
    return [(f"centroidal.{key}.{leg}", reader.vector(reader.get(mapping, leg, f"centroidal.{key}.{leg}"),
                                                      f"centroidal.{key}.{leg}", length)) for leg in legs]


def _inertia(reader: FieldReader, section: dict) -> np.ndarray:
    values = reader.get(section, "inertia", "centroidal.inertia", dict)
    unknown = sorted(set(values) - set(INERTIA_KEYS))
    if unknown:
        reader.fail(f"centroidal.inertia.{unknown[0]}", f"is unknown (expected {', '.join(INERTIA_KEYS)})")
    ixx, iyy, izz, ixy, ixz, iyz = (reader.number(reader.get(values, key, f"centroidal.inertia.{key}"),
                                                  f"centroidal.inertia.{key}") for key in INERTIA_KEYS)
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    moments = np.linalg.eigvalsh(inertia)
    if moments[0] <= 0:
        reader.fail("centroidal.inertia", f"must be positive definite (principal moments "
                    f"{', '.join(f'{m:.6g}' for m in moments)} kg m^2)")
    if moments[0] + moments[1] < moments[2] * (1 - 1e-12):
        reader.fail("centroidal.inertia", f"is no rigid body's: principal moments {moments[0]:.6g} + "
                    f"{moments[1]:.6g} < {moments[2]:.6g} kg m^2 (triangle inequality)")
    return inertia


def _nominal_feet(reader: FieldReader, section: dict, legs: tuple[str, ...]) -> np.ndarray:
    rows = []
    for field, row in _per_leg(reader, section, "nominal_feet", legs, 3):
        if row[2] >= 0:
            reader.fail(field, f"must be below the base (z < 0), got z = {row[2]:g}")
        rows.append(row)
    return np.array(rows)
