"""What the scan shows around a hole, for the report: a small height map of its points seen along the normal.

A failed hole is a bad hole or a bad measurement: a chip on the rim, a burr, lubricant pooled in the
countersink, a hole the profiler saw only in part. The numbers cannot tell these apart; the points
can. :func:`height_map` bins the points around a hole, in the hole's plane frame (as :mod:`holecli.plot`
draws it), into a square image of their height above the surface: the surface is white, what stands
above it (a burr, a chip) red, what lies below it (the countersink, the bore wall, a floor) blue, and
where the scan has no point (the open hole) grey. :func:`png_bytes` encodes it (matplotlib, the extra
``plot``). Pure: points in, an array or PNG bytes out.

Examples
--------
>>> import numpy as np
>>> a, b = np.meshgrid(np.linspace(-4, 4, 81), np.linspace(-4, 4, 81))
>>> keep = np.hypot(a, b) > 1.5  # a 3 mm hole in a flat sheet
>>> points = np.column_stack([a[keep], b[keep], np.zeros(keep.sum())])
>>> heights = height_map(points, center=[0, 0, 0], normal=[0, 0, 1], radius=1.5, pixels=32)
>>> heights.shape, bool(np.isnan(heights[16, 16])), float(np.nanmax(np.abs(heights)))
((32, 32), True, 0.0)
"""

from __future__ import annotations

import io

import numpy as np

from holecli.plot import plane_frame

VIEW_RADII = 1.6
"""The half width of the view, in hole radii: the rim and a ring of the surface around it."""


def height_map(points, center, normal, radius, *, pixels=96, view_radii=VIEW_RADII) -> np.ndarray:
    """The heights of the points around a hole above its surface, binned into a square image.

    Parameters
    ----------
    points : (N, 3) float array
        The scan (non-finite points are left out).
    center, normal : (3,) float
        The hole's center on the surface and its unit normal (the record's).
    radius : float
        The hole's radius (> 0).
    pixels : int
        The image's width and height.
    view_radii : float
        The half width of the view, in radii.

    Returns
    -------
    (pixels, pixels) float ndarray
        Row 0 at the top (+v), column 0 at the left (-u), in the frame of :func:`holecli.plot.plane_frame`;
        each pixel the height (along the normal) of the highest point that falls in it, NaN where none does.

    Raises
    ------
    ValueError
        For a radius that is not a positive finite number, or fewer than 2 pixels.
    """
    if not np.isfinite(radius) or radius <= 0:
        raise ValueError(f"radius must be a positive finite number, got {radius!r}")
    if pixels < 2:
        raise ValueError(f"pixels must be at least 2, got {pixels!r}")
    normal = np.asarray(normal, dtype=float)
    normal = normal / np.linalg.norm(normal)
    u, v = plane_frame(normal)
    half = view_radii * radius
    points = np.asarray(points, dtype=float)
    offsets = points - np.asarray(center, dtype=float)
    # a cube around the hole first (cheap), then the frame's coordinates of those points only
    near = np.all(np.abs(offsets) <= half * 1.8, axis=1)
    offsets = offsets[near]
    a, b, h = offsets @ u, offsets @ v, offsets @ normal
    keep = (np.abs(a) < half) & (np.abs(b) < half) & np.isfinite(h)
    column = ((a[keep] + half) / (2 * half) * pixels).astype(int).clip(0, pixels - 1)
    row = ((half - b[keep]) / (2 * half) * pixels).astype(int).clip(0, pixels - 1)
    image = np.full(pixels * pixels, -np.inf)
    np.maximum.at(image, row * pixels + column, h[keep])
    image[np.isneginf(image)] = np.nan
    return image.reshape(pixels, pixels)


def png_bytes(heights, limit) -> bytes:
    """The height map as a PNG: white at the surface, red above it, blue below, grey where no point is.

    Parameters
    ----------
    heights : (H, W) float array
        :func:`height_map`'s.
    limit : float
        The height drawn in full colour (above it: the same red; below ``-limit``: the same blue).

    Returns
    -------
    bytes

    Raises
    ------
    ImportError
        Without matplotlib (``pip install 'holecli[plot]'``).
    """
    import matplotlib

    from matplotlib import colormaps
    from matplotlib import image as mpl_image

    del matplotlib
    scaled = np.clip(np.asarray(heights, dtype=float) / (2.0 * limit) + 0.5, 0.0, 1.0)
    rgba = colormaps["coolwarm"](np.nan_to_num(scaled, nan=0.5))
    rgba[np.isnan(heights)] = (0.45, 0.45, 0.45, 1.0)
    buffer = io.BytesIO()
    mpl_image.imsave(buffer, rgba, format="png")
    return buffer.getvalue()


def hole_view(points, hole, *, spacing=None, max_pixels=96) -> dict | None:
    """The picture of one hole of a record as its scan shows it.

    Parameters
    ----------
    points : (N, 3) float array
        The scan, in the record's length unit.
    hole : dict
        A hole of the record (``center``, ``normal``, ``diameter``).
    spacing : float, optional
        The scan's point spacing (the record's ``scales.point_spacing``): a pixel is at least this wide,
        so that the surface shows whole rather than as a grid of single points.
    max_pixels : int
        The most pixels across the picture.

    Returns
    -------
    dict or None
        ``{"png": bytes, "half_width": the view's half width (record unit), "limit": the height of full
        colour, "pixels_seen": the pixels a point falls in}``; None when the hole's values are not finite or no point of
        the scan lies in the view (the scan is not this record's).
    """
    try:
        center = np.asarray(hole["center"], dtype=float)
        normal = np.asarray(hole["normal"], dtype=float)
        radius = float(hole["diameter"]) / 2.0
    except (KeyError, TypeError, ValueError):
        return None
    if not (np.all(np.isfinite(center)) and np.all(np.isfinite(normal)) and np.isfinite(radius) and radius > 0):
        return None
    width = 2 * VIEW_RADII * radius
    pixels = max_pixels
    if spacing is not None and np.isfinite(spacing) and spacing > 0:
        pixels = int(np.clip(np.floor(width / (1.5 * spacing)), 16, max_pixels))
    heights = height_map(points, center, normal, radius, pixels=pixels)
    seen = int(np.count_nonzero(np.isfinite(heights)))
    if seen == 0:
        return None
    limit = max(0.25 * radius, 1e-9)
    return {"png": png_bytes(heights, limit), "half_width": VIEW_RADII * radius, "limit": limit, "pixels_seen": seen}
