import numpy as np
import pytest
import shapely

from guided_sfm.core.rule.frustum import frustum_polygons, frustum_vertices


def test_vertices_apex_axis_and_height():
    vertices = frustum_vertices([0.0, 1.0], [0.0, 2.0], [90.0, 0.0], [90.0, 60.0], [1.0, 3.0])
    assert vertices.shape == (2, 3, 2)
    np.testing.assert_allclose(vertices[0], [[0, 0], [1, 1], [-1, 1]], atol=1e-12)
    apex, right, left = vertices[1]
    np.testing.assert_allclose(apex, [1, 2])
    np.testing.assert_allclose((right + left) / 2 - apex, [3, 0], atol=1e-12)  # height = range
    assert np.linalg.norm(right - left) == pytest.approx(2 * 3 * np.tan(np.radians(30)))


def test_polygons_are_shapely_triangles():
    polygons = frustum_polygons([0, 5], [0, 0], [0, 0], [60, 60], [2, 2])
    assert polygons.shape == (2,)
    assert all(isinstance(p, shapely.Polygon) for p in polygons)
    assert polygons[0].area == pytest.approx(2 * 2 * np.tan(np.radians(30)))


def test_triangles_touching_at_one_apex_intersect():
    facing_away = frustum_polygons([0, 0], [0, 0], [0, 180], [60, 60], [5, 5])
    assert facing_away[0].intersection(facing_away[1]).geom_type == "Point"
    assert shapely.intersects(facing_away[0], facing_away[1])


def test_triangle_touching_a_corner_intersects():
    corner = frustum_vertices(0, 0, 0, 90, 1)[0, 2]  # exactly the stored float vertex
    first = frustum_polygons(0, 0, 0, 90, 1)[0]
    second = frustum_polygons(corner[0], corner[1], 45, 60, 1)[0]
    assert first.intersection(second).geom_type == "Point"
    assert shapely.intersects(first, second)


def test_disjoint_triangles_do_not_intersect():
    a, b = frustum_polygons([0, 10], [0, 0], [0, 0], [60, 60], [5, 5])
    assert not shapely.intersects(a, b)
