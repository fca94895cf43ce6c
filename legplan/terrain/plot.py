"""Figures of a `TerrainMap`: shaded heightmap, foothold mask, costmap, each with a scale bar."""

from __future__ import annotations

import os

import numpy as np

from legplan.artefacts.publish import save_figure
from legplan.terrain.terrain_map import TerrainMap


def _scale_bar_length(width: float) -> float:
    """A round length (1, 2 or 5 x 10^k m) near a fifth of `width`."""
    target = width / 5
    power = 10 ** np.floor(np.log10(target))
    return float(max((m * power for m in (1, 2, 5) if m * power <= target), default=power))


def _add_scale_bar(axes, width: float) -> None:
    from matplotlib.font_manager import FontProperties
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    length = _scale_bar_length(width)
    label = f"{length:g} m" if length >= 1 else f"{length * 100:g} cm"
    axes.add_artist(AnchoredSizeBar(axes.transData, length, label, "lower right", pad=0.4,
                                    color="black", frameon=True, size_vertical=width / 150,
                                    fontproperties=FontProperties(size=8)))


def render_map(terrain: TerrainMap, path: str | os.PathLike, dpi: int = 120, *, overwrite: bool = False) -> None:
    """Write a PNG with three panels: heightmap (hill-shaded), foothold mask, costmap."""
    import matplotlib
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LightSource, Normalize
    from matplotlib.figure import Figure

    extent = terrain.grid.extent
    width, depth = extent[1] - extent[0], extent[3] - extent[2]
    aspect = depth / width
    figure = Figure(figsize=(15, max(3.0, 4.6 * aspect + 0.8)), layout="constrained")
    axes = figure.subplots(1, 3)
    height = terrain.height
    low, high = float(height.min()), float(height.max())
    shade = LightSource(azdeg=315, altdeg=45)
    cmap = matplotlib.colormaps["viridis"]
    norm = Normalize(low, high if high > low else low + 1e-3)
    rgb = shade.shade(height, cmap=cmap, norm=norm, blend_mode="soft",
                      vert_exag=1.0 / terrain.grid.resolution * 0.2)
    axes[0].imshow(rgb, origin="lower", extent=extent)
    figure.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=axes[0], label="height [m]",
                    shrink=0.8)
    axes[0].set_title(f"{terrain.name or 'terrain'}: height")
    axes[1].imshow(height, origin="lower", extent=extent, cmap="Greys_r", norm=norm, alpha=0.6)
    overlay = np.ma.masked_where(~terrain.foothold, np.ones_like(height))
    axes[1].imshow(overlay, origin="lower", extent=extent, cmap="summer", vmin=0, vmax=2, alpha=0.8)
    axes[1].set_title(f"footholds (green, {terrain.foothold.mean():.0%} of cells)")
    nav = terrain.nav_params
    image = axes[2].imshow(terrain.costmap, origin="lower", extent=extent, cmap="inferno_r",
                           vmin=0, vmax=nav.c_max)
    figure.colorbar(image, ax=axes[2], label="cost", shrink=0.8)
    axes[2].set_title(f"costmap (l1 {nav.l1:g} m, l2 {nav.l2:g} m, λc {nav.lambda_c:g})")
    for ax in axes:
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        _add_scale_bar(ax, width)
    save_figure(figure, path, overwrite=overwrite, dpi=dpi)
