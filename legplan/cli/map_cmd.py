"""`legplan map build|import|show`: terrain maps (heightmap, SDF, footholds, costmap) as map.h5."""

from __future__ import annotations

import click

from legplan.cli.console import progress_bar, status
from legplan.cli.options import ShippedPath, input_artefact, number, output_opt, overwrite_opt, verbosity_opts
from legplan.cli.options import pose
from legplan.parameters import LENGTH, RESOLUTION, SCALE


@click.group("map")
@verbosity_opts
def command():
    """Build, import and draw terrain maps (kind "map")."""


@command.command("build")
@click.argument("spec", type=ShippedPath("maps"))
@output_opt
@overwrite_opt
@verbosity_opts
def build(spec, output, overwrite):
    """Build a map from a YAML SPEC (a path, or a shipped map by name: gap_crossing, flat, ...):
    heightmap, SDF, footholds, occupancy, costmap."""
    from legplan.artefacts import check_output
    from legplan.terrain import build_map, save_map

    check_output(output, overwrite)
    with progress_bar("building SDF") as progress:
        terrain = build_map(spec, progress=progress)
    save_map(terrain, output, params={"spec": str(spec)}, inputs=[spec], overwrite=overwrite)
    _report(terrain, output)


@command.command("import")
@click.argument("kind", type=click.Choice(["ros", "movingai", "heightmap"]))
@click.argument("path", type=ShippedPath("maps"))
@output_opt
@click.option("--resolution", type=number(RESOLUTION), help="Cell size (m); required for movingai and heightmap "
                                                 "(ros maps carry their own).")
@click.option("--origin", type=pose(2), default=(0.0, 0.0), show_default=True,
              help="movingai: lower-left corner of the grid; heightmap: centre of cell [0, 0] (m).")
@click.option("--scale", type=number(SCALE), default=1.0, show_default=True,
              help="heightmap: metres per unit of the stored value (image grey levels are 0..1).")
@click.option("--obstacle-height", type=number(LENGTH), default=1.0, show_default=True,
              help="ros/movingai: height (m) of the columns that obstacle cells become.")
@overwrite_opt
@verbosity_opts
def import_(kind, path, output, resolution, origin, scale, obstacle_height, overwrite):
    """Import a ROS map_server YAML, a MovingAI .map or a PNG/PGM/NPY heightmap as a map."""
    from legplan.artefacts import check_output
    from legplan.errors import LegplanError
    from legplan.terrain import save_map
    from legplan.terrain.importers import import_heightmap, import_movingai, import_ros

    check_output(output, overwrite)
    if kind != "ros" and (resolution is None or resolution <= 0):
        raise LegplanError(f"{path}: option '--resolution' must be given and > 0 for {kind} maps")
    if obstacle_height <= 0:
        raise LegplanError(f"{path}: option '--obstacle-height' must be > 0")
    with progress_bar("building SDF") as progress:
        if kind == "ros":
            terrain = import_ros(path, obstacle_height=obstacle_height, progress=progress)
        elif kind == "movingai":
            terrain = import_movingai(path, resolution, origin, obstacle_height=obstacle_height,
                                      progress=progress)
        else:
            terrain = import_heightmap(path, resolution, origin, scale, progress=progress)
    params = {"format": kind, "resolution": resolution, "origin": list(origin), "scale": scale,
              "obstacle_height": obstacle_height}
    inputs = [path]
    if kind == "ros":
        from pathlib import Path

        from legplan.specio import read_yaml_mapping

        inputs.append(Path(path).parent / read_yaml_mapping(path, "ROS map file")["image"])
    save_map(terrain, output, params=params, inputs=inputs, overwrite=overwrite)
    _report(terrain, output)


@command.command("show")
@click.argument("path", type=input_artefact)
@output_opt
@overwrite_opt
@verbosity_opts
def show(path, output, overwrite):
    """Draw a map: shaded heightmap, foothold mask and costmap, with scale bars (PNG)."""
    from legplan.artefacts import check_output
    from legplan.terrain import load_map
    from legplan.terrain.plot import render_map

    check_output(output, overwrite)
    render_map(load_map(path), output, overwrite=overwrite)
    status(f"wrote {output}")


def _report(terrain, output) -> None:
    ny, nx = terrain.grid.shape
    summary = terrain.summary()
    status(f"wrote {output}: {terrain.name} {nx}x{ny} cells at {terrain.grid.resolution:g} m, "
               f"SDF {terrain.sdf.shape[0]} layers, height {summary['height_min'][0]:.3g}.."
               f"{summary['height_max'][0]:.3g} m, footholds {summary['foothold_fraction']:.1%}, "
               f"occupied {summary['occupied_fraction']:.1%}")
