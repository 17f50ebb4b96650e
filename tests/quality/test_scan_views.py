"""holecli.quality.scan_views: the points around a hole as a height map, to tell debris from a bad hole."""

import numpy as np
import pytest

from holecli.quality.scan_views import VIEW_RADII, height_map, hole_view, png_bytes


def sheet_with_hole(radius=2.0, spacing=0.1, extent=6.0):
    a, b = np.meshgrid(np.arange(-extent, extent + 1e-9, spacing), np.arange(-extent, extent + 1e-9, spacing))
    keep = np.hypot(a, b) > radius
    return np.column_stack([a[keep], b[keep], np.zeros(keep.sum())])


def test_the_open_hole_is_empty_and_the_surface_is_at_height_zero():
    heights = height_map(sheet_with_hole(), [0, 0, 0], [0, 0, 1], 2.0, pixels=40)
    assert np.isnan(heights[20, 20]) and np.isnan(heights[18:22, 18:22]).all()
    assert np.nanmax(np.abs(heights)) == 0.0
    assert np.isfinite(heights[0, 0]) and np.isfinite(heights[-1, -1])  # the corners are surface


def test_a_chip_standing_in_the_hole_shows_above_the_surface_where_it_is():
    chip = np.array([[1.0, 0.0, 0.3], [1.05, 0.0, 0.3]])  # inside the hole, on its +u side, 0.3 above
    heights = height_map(np.vstack([sheet_with_hole(), chip]), [0, 0, 0], [0, 0, 1], 2.0, pixels=40)
    row, column = np.unravel_index(np.nanargmax(heights), heights.shape)
    assert heights[row, column] == pytest.approx(0.3)
    assert column > 20 and row in (19, 20)  # right of the center (+u), at mid height


def test_the_view_follows_the_hole_s_frame():
    # the same sheet tilted: the heights are along the normal, so the surface is still at 0
    angle = np.radians(30)
    rotation = np.array([[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]])
    points = sheet_with_hole() @ rotation.T + [10, 20, 30]
    heights = height_map(points, [10, 20, 30], rotation @ [0, 0, 1], 2.0, pixels=40)
    assert np.nanmax(np.abs(heights)) < 1e-9 and np.isnan(heights[20, 20])


@pytest.mark.parametrize("radius, pixels, message", [(0.0, 10, "radius"), (np.nan, 10, "radius"), (1.0, 1, "pixels")])
def test_bad_arguments_are_refused(radius, pixels, message):
    with pytest.raises(ValueError, match=message):
        height_map(sheet_with_hole(), [0, 0, 0], [0, 0, 1], radius, pixels=pixels)


def test_png_bytes_is_a_png():
    pytest.importorskip("matplotlib")
    data = png_bytes(np.array([[0.0, np.nan], [1.0, -1.0]]), limit=1.0)
    assert data.startswith(b"\x89PNG\r\n\x1a\n")


def test_a_pixel_is_no_finer_than_the_scan_s_spacing():
    pytest.importorskip("matplotlib")
    hole = {"center": [0, 0, 0], "normal": [0, 0, 1], "diameter": 4.0}
    coarse = hole_view(sheet_with_hole(spacing=0.2), hole, spacing=0.2)
    fine = hole_view(sheet_with_hole(spacing=0.05), hole, spacing=0.05, max_pixels=96)
    assert coarse["half_width"] == pytest.approx(VIEW_RADII * 2.0)
    # 6.4 mm across at 0.2 mm: 21 pixels of 0.3 mm, every one with a point (no grid of gaps) on the surface
    assert coarse["pixels_seen"] < fine["pixels_seen"]
    assert coarse["pixels_seen"] == pytest.approx(21 * 21 * (1 - np.pi * 4 / 6.4 ** 2), rel=0.1)


def test_a_scan_that_is_not_the_record_s_gives_no_view():
    hole = {"center": [500, 500, 0], "normal": [0, 0, 1], "diameter": 4.0}
    assert hole_view(sheet_with_hole(), hole) is None
    assert hole_view(sheet_with_hole(), {"center": None, "normal": [0, 0, 1], "diameter": 4.0}) is None
    assert hole_view(sheet_with_hole(), {"center": [0, 0, 0], "normal": [0, 0, 1], "diameter": float("nan")}) is None
