"""`legplan robot list|show|init|check`: the robots on the search path, what their model holds, drafting
and checking a robot.yaml."""

from __future__ import annotations

import json

import click

from legplan.cli.options import OutputPath, json_opt, number, overwrite_opt, verbosity_opts
from legplan.parameters import FORCE, FRICTION, LENGTH


@click.group("robot")
@verbosity_opts
def command():
    """Robot models: <folder>/<name>/robot.urdf + robot.yaml, found on LEGPLAN_ROBOTS (colon-separated
    folders) and then in the shipped robots; `init` drafts a robot.yaml, `check` validates one."""


@command.command("list")
@json_opt
@verbosity_opts
def list_command(as_json):
    """List the robots on the search path with their DOF and legs; a folder that does not load is
    listed as broken with its reason (exit 0)."""
    from legplan.robots import robot_search_path, survey_robots

    rows = []
    for entry in survey_robots():
        robot = entry.robot
        row = {"name": entry.name, "folder": str(entry.folder), "broken": entry.problem}
        if robot is not None:
            row.update({"dof": robot.nv, "nq": robot.nq, "legs": robot.n_legs, "spheres": len(robot.spheres),
                        "mass": robot.mass, "navigation": robot.navigation is not None,
                        "centroidal": robot.centroidal is not None, "description": robot.description})
        rows.append(row)
    if as_json:
        click.echo(json.dumps(rows, indent=2))
        return
    click.echo("robots in " + ", then ".join(str(root) for root in robot_search_path()) + ":")
    for row in rows:
        if row["broken"]:
            click.echo(f"  {row['name']:<14} broken: {row['broken']}")
            continue
        extras = "".join(f", {key}" for key in ("navigation", "centroidal") if row[key])
        click.echo(f"  {row['name']:<14} {row['dof']:>3} DOF  {row['legs']} legs  {row['spheres']:>3} spheres  "
                   f"{row['mass']:.2f} kg{extras}")


def _foot_option(text: str) -> tuple[str, tuple[str, list[float] | None]]:
    """`LEG=LINK[:X,Y,Z]` -> (leg, (link, offset or None)); a `click.BadParameter` (exit 2) otherwise."""
    from legplan.errors import SpecError
    from legplan.specio import parse_number

    leg, sep, rest = text.partition("=")
    link, _, offset = rest.partition(":")
    if not sep or not leg or not link:
        raise click.BadParameter(f"{text!r}: expected LEG=LINK or LEG=LINK:X,Y,Z", param_hint="--foot")
    if not offset:
        return leg, (link, None)
    parts = offset.split(",")
    try:
        values = [parse_number(v, f"--foot {leg}") for v in parts]
    except SpecError as exc:
        raise click.BadParameter(str(exc), param_hint="--foot") from None
    if len(values) != 3:
        raise click.BadParameter(f"{text!r}: the offset needs 3 numbers X,Y,Z (m)", param_hint="--foot")
    return leg, (link, values)


@command.command("init")
@click.argument("urdf", type=click.Path(dir_okay=False))
@click.option("-o", "--output", "folder", required=True, type=OutputPath(file_okay=False, files=("robot.yaml",)),
              help="Robot folder to write robot.yaml into (created; e.g. robots/NAME/).")
@click.option("--name", default=None, help="Robot name (default: the folder's name).")
@click.option("--foot", "feet", multiple=True, metavar="LEG=LINK[:X,Y,Z]",
              help="A leg's foot: on LINK at offset X,Y,Z (m, link frame), or at the lowest point of LINK's "
                   "geometry in the stance when no offset is given. Repeatable.")
@click.option("--height", type=number(LENGTH), default=None,
              help="Base height of the nominal stance (m); default: legs bent to 0.65-0.8 of their "
                   "drop, the share with the largest range of motion whose legs hold a trot (legplan.robots.draft).")
@click.option("--package-path", "package_paths", multiple=True, type=click.Path(file_okay=False),
              help="A folder holding ROS packages (or a package itself) for package:// meshes; searched "
                   "before the URDF's parent folders and ROS_PACKAGE_PATH. Repeatable.")
@click.option("--friction", type=number(FRICTION), default=None,
              help="centroidal.friction (default 0.5).")
@click.option("--max-normal-force", type=number(FORCE), default=None,
              help="centroidal.max_normal_force (N); default: from the joint efforts.")
@click.option("--no-centroidal", "no_centroidal", is_flag=True,
              help="Draft no centroidal section (legs that cannot move their feet in 3D, robots not for dyn).")
@overwrite_opt
@verbosity_opts
def init_command(urdf, folder, name, feet, height, package_paths, friction, max_normal_force, no_centroidal,
                 overwrite):
    """Draft robot.yaml for URDF: leg chains, feet (the URDF's foot links, else the far end of each
    last link), collision spheres, joint limits, a nominal stance on the ground and the centroidal
    section (legplan.robots.draft; the URDF is not edited). Review it, then run `legplan robot check`."""
    from legplan.cli.console import stderr_line
    from legplan.robots.draft import DRAFT_FRICTION, DraftOptions, write_draft

    options = DraftOptions(feet=dict(_foot_option(text) for text in feet), height=height,
                           package_paths=tuple(package_paths),
                           friction=DRAFT_FRICTION if friction is None else friction,
                           max_normal_force=max_normal_force, centroidal=not no_centroidal)
    path, draft = write_draft(urdf, folder, name, overwrite, options)
    for warning in draft.warnings:
        stderr_line(warning, "warning:", "bold yellow")
    click.echo(f"{path}: drafted; next: legplan robot check {path.parent}")


@command.command("check")
@click.argument("robot")
@click.option("--package-path", "package_paths", multiple=True, type=click.Path(file_okay=False),
              help="A folder holding ROS packages (or a package itself) for package:// meshes. Repeatable.")
@json_opt
@verbosity_opts
@click.pass_context
def check_command(ctx, robot, package_paths, as_json):
    """Check ROBOT (a name or a path to a robot folder / robot.yaml): feet at the distal end of each
    chain, base height, nominal stance on the ground with no sphere in it, the centroidal section
    against the URDF (mass, inertia, CoM, nominal feet, range of motion reachable by IK, force limit
    against the joint efforts) and link inertias. One line per finding naming its field; errors
    exit 1, warnings and notes do not. legplan.robots.check lists the rules."""
    from legplan.robots import load_robot
    from legplan.robots.check import check_robot

    model = load_robot(robot, strict=False)
    findings = check_robot(model, package_paths)
    errors = [f for f in findings if f.severity == "error"]
    warnings = [f for f in findings if f.severity == "warning"]
    if as_json:
        click.echo(json.dumps([vars(f) for f in findings], indent=2))
    else:
        for finding in findings:
            click.echo(f"{finding.severity}: {finding}")
        click.echo(f"{model.name}: {len(errors)} errors, {len(warnings)} warnings")
    if errors:
        ctx.exit(1)


def robot_summary(robot) -> dict:
    """Everything `robot show` prints, as JSON-ready data."""
    spheres = robot.spheres
    summary = {
        "name": robot.name, "description": robot.description, "yaml": str(robot.yaml_path),
        "urdf": str(robot.urdf_path), "nq": robot.nq, "nv": robot.nv, "n_joints": robot.n_joints,
        "mass": robot.mass, "base_height": float(robot.q_nominal[2]),
        "legs": [{"name": leg.name, "joints": list(leg.joint_names), "foot_frame": leg.foot_frame}
                 for leg in robot.legs],
        "joints": [{"name": name, "lower": float(lo), "upper": float(hi), "nominal": float(q)}
                   for name, lo, hi, q in zip(robot.joint_names, robot.lower, robot.upper,
                                              robot.q_nominal[7:])],
        "spheres": [{"frame": spheres.frame_names[k], "offset": spheres.offsets[k].tolist(),
                     "radius": float(spheres.radii[k]),
                     "leg": robot.legs[spheres.leg_index[k]].name if spheres.leg_index[k] >= 0 else None,
                     "foot": bool(spheres.is_foot[k])} for k in range(len(spheres))],
        "navigation": None,
        "centroidal": None,
    }
    nav = robot.navigation
    if nav is not None:
        summary["navigation"] = {"footprint": nav.footprint.tolist(),
                                 "inscribed_radius": nav.inscribed_radius,
                                 "circumscribed_radius": nav.circumscribed_radius,
                                 "limits": vars(nav.limits)}
    c = robot.centroidal
    if c is not None:
        from legplan.robots import torque_limits

        limits = torque_limits(robot)
        summary["centroidal"] = {"mass": c.mass, "inertia": c.inertia.tolist(), "com_offset": c.com_offset.tolist(),
                                 "nominal_feet": dict(zip(c.legs, c.nominal_feet.tolist())),
                                 "range_of_motion": c.range_of_motion.tolist(), "base_height": c.base_height,
                                 "max_normal_force": c.max_normal_force, "friction": c.friction,
                                 "torque_limits": None if limits is None else
                                 {leg.name: values.tolist() for leg, values in zip(robot.legs, limits)},
                                 "torque_limits_from": None if limits is None else
                                 "robot.yaml" if c.torque_limits is not None else "URDF efforts"}
    return summary


@command.command("show")
@click.argument("robot")
@click.option("--png", type=OutputPath(dir_okay=False), help="Also draw the nominal stance to this PNG.")
@overwrite_opt
@json_opt
@verbosity_opts
def show_command(robot, png, overwrite, as_json):
    """Show ROBOT (a name or a path to a robot folder / robot.yaml): DOF, legs, limits, spheres."""
    from legplan.artefacts import check_output
    from legplan.robots import load_robot
    from legplan.robots.navigation import LIMIT_UNITS

    if png:
        check_output(png, overwrite)
    model = load_robot(robot)
    info = robot_summary(model)
    if png:
        from legplan.robots.draw import draw_robot

        draw_robot(model, model.q_nominal, png, overwrite=overwrite)
    if as_json:
        click.echo(json.dumps(info, indent=2))
        return
    click.echo(f"{info['name']}: {info['nv']} DOF (nq {info['nq']}), {len(info['legs'])} legs, "
               f"{info['n_joints']} joints, {len(info['spheres'])} spheres, {info['mass']:.3f} kg")
    if info["description"]:
        click.echo(f"  {info['description']}")
    click.echo(f"  spec: {info['yaml']}\n  urdf: {info['urdf']}")
    click.echo(f"  nominal base height: {info['base_height']:.4f} m")
    click.echo("  legs:")
    for leg in info["legs"]:
        click.echo(f"    {leg['name']}: {' -> '.join(leg['joints'])} -> {leg['foot_frame']}")
    click.echo("  joint limits [rad] (nominal):")
    for joint in info["joints"]:
        click.echo(f"    {joint['name']:<16} [{joint['lower']:+.3f}, {joint['upper']:+.3f}]  ({joint['nominal']:+.3f})")
    click.echo("  collision spheres:")
    for sphere in info["spheres"]:
        owner = "body" if sphere["leg"] is None else f"leg {sphere['leg']}"
        foot = ", foot" if sphere["foot"] else ""
        offset = ", ".join(f"{v:+.4f}" for v in sphere["offset"])
        click.echo(f"    {sphere['frame']:<16} r {sphere['radius']:.4f} m at ({offset})  [{owner}{foot}]")
    nav = info["navigation"]
    if nav is None:
        click.echo("  navigation: none")
    else:
        click.echo(f"  navigation: footprint {nav['footprint']} m, inscribed radius "
                   f"{nav['inscribed_radius']:.4f} m, circumscribed radius {nav['circumscribed_radius']:.4f} m")
        for name, value in nav["limits"].items():
            click.echo(f"    {name:<10} {value:g} {LIMIT_UNITS[name]}")
    c = info["centroidal"]
    if c is None:
        click.echo("  centroidal: none")
    else:
        click.echo(f"  centroidal: {c['mass']:g} kg, base height {c['base_height']:g} m, max normal force "
                   f"{c['max_normal_force']:g} N, friction {c['friction']:g}, range of motion "
                   f"+-{c['range_of_motion']} m")
        click.echo(f"    inertia [kg m^2]: {c['inertia']}")
        click.echo(f"    CoM in the base frame: {c['com_offset']} m")
        for leg, foot in c["nominal_feet"].items():
            click.echo(f"    nominal foot {leg}: {foot} m")
        if c["torque_limits"] is None:
            click.echo("    torque limits: none (placeholder efforts: the forces bounded by the max normal force and "
                       "friction alone)")
        else:
            joints = {leg["name"]: leg["joints"] for leg in info["legs"]}
            for leg, limits in c["torque_limits"].items():
                shown = ", ".join(f"{joint} {limit:g}" for joint, limit in zip(joints[leg], limits))
                click.echo(f"    torque limits {leg} [N m, {c['torque_limits_from']}]: {shown}")
    if png:
        click.echo(f"  stance picture: {png}")
