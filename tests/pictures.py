"""What a PNG shows, for tests of figures: pixel statistics (is the drawn data there?), not file sizes."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import to_rgb
from PIL import Image


def pixels(path) -> np.ndarray:
    """(height, width, 3) integer RGB of a PNG."""
    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def share(image: np.ndarray, colour: str | tuple, tolerance: int = 12) -> float:
    """Fraction of pixels within `tolerance` (sum of |Δ| over R, G, B) of `colour` (a matplotlib
    colour name or an RGB triple in 0..255)."""
    rgb = np.rint(np.array(to_rgb(colour)) * 255) if isinstance(colour, str) else np.asarray(colour)
    return float((np.abs(image - rgb).sum(axis=2) <= tolerance).mean())


def drawn(image: np.ndarray) -> float:
    """Fraction of pixels that are not white (axes, data, labels)."""
    return float((image < 250).any(axis=2).mean())
