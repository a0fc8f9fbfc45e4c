import numpy as np
import pycolmap
import pytest

from guided_sfm.core import geometry
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.topdown import build_scene
from guided_sfm.sample.geometry import look

FOCAL, WIDTH, HEIGHT = 500.0, 640, 480
GROUND = np.array([[x, y, 0.0] for x in np.linspace(-12, 20, 33) for y in np.linspace(-12, 12, 25)])
# name, image id, centre, yaw: a line of level cameras 1.5 m above the ground z = 0
HAND_MADE = [("a.png", 3, (0.0, 0.0, 1.5), 0.0), ("b.png", 1, (4.0, 0.0, 1.5), 90.0),
             ("c.png", 2, (8.0, 0.0, 1.5), 180.0)]


def _visible(rotation, translation, points):
    in_cam = points @ rotation.T + translation
    with np.errstate(divide="ignore", invalid="ignore"):
        pixels = FOCAL * in_cam[:, :2] / in_cam[:, 2:] + [WIDTH / 2, HEIGHT / 2]
    inside = (in_cam[:, 2] > 0.1) & np.all((pixels >= 0) & (pixels < [WIDTH, HEIGHT]), axis=1)
    return inside, pixels, in_cam[:, 2]


def _model(cameras, points=GROUND, camera_id=1) -> pycolmap.Reconstruction:
    """A reconstruction of level pinhole cameras observing every ground point they see."""
    model = pycolmap.Reconstruction()
    model.add_camera_with_trivial_rig(pycolmap.Camera.create_from_model_name(
        camera_id, "SIMPLE_PINHOLE", FOCAL, WIDTH, HEIGHT))
    tracks = [pycolmap.Track() for _ in points]
    for name, image_id, center, yaw in cameras:
        rotation, translation = look(center, yaw)
        inside, pixels, _ = _visible(rotation, translation, points)
        image = pycolmap.Image(name=name, keypoints=pixels[inside], camera_id=camera_id,
                               image_id=image_id)
        model.add_image_with_trivial_frame(image, pycolmap.Rigid3d(
            pycolmap.Rotation3d(rotation), translation))
        for point2d_idx, point_idx in enumerate(np.flatnonzero(inside)):
            tracks[point_idx].add_element(image_id, point2d_idx)
    for xyz, track in zip(points, tracks, strict=True):
        if track.length() > 0:
            model.add_point3D(xyz, track)
    return model


def _expected_range(center, yaw) -> float:
    inside, _, depth = _visible(*look(center, yaw), GROUND)
    return float(np.median(depth[inside]))


def _build(models, images, folder, **options):
    """build_scene on in-memory models: the largest is written to folder, where its points are read."""
    if models:
        models[0].write_binary(folder)
    return build_scene(models, folder, images, **options)


def test_hand_made_scene_positions_yaws_and_ranges(tmp_path):
    scene = _build([_model(HAND_MADE)], [(i, n) for n, i, _, _ in HAND_MADE], tmp_path)
    np.testing.assert_allclose(scene.frame.up, [0, 0, 1], atol=1e-9)
    np.testing.assert_allclose(scene.frame.x_axis, [1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(scene.frame.origin, [4, 0, 0], atol=1e-9)
    fov = np.degrees(2 * np.arctan(WIDTH / (2 * FOCAL)))
    for camera, (name, image_id, center, yaw) in zip(scene.cameras, HAND_MADE, strict=True):
        assert (camera.name, camera.image_id, camera.registered, camera.model) == \
            (name, image_id, True, 0)
        assert (camera.x, camera.y) == pytest.approx((center[0] - 4.0, 0.0), abs=1e-9)
        assert camera.yaw_deg == pytest.approx(geometry.wrap_deg(yaw), abs=1e-9)
        assert camera.fov_deg == pytest.approx(fov)
        assert camera.range == pytest.approx(_expected_range(center, yaw))
        assert camera.center == pytest.approx(center)
        rotation = geometry.rotation_from_qvec(camera.qvec)
        np.testing.assert_allclose(rotation, look(center, yaw)[0], atol=1e-9)
    assert [c.seq for c in scene.cameras] == [0, 1, 2]


def test_unregistered_images_other_models_and_blind_cameras(tmp_path):
    blind = ("d.png", 4, (4.0, 0.0, 1.5), 0.0)
    away = [(n, i, (c[0], c[1], 50.0), y) for n, i, c, y in [blind]]  # looks at the horizon
    largest = _model(HAND_MADE + away)
    other = _model([("e.png", 5, (0.0, 5.0, 1.5), 90.0)], camera_id=2)
    images = [(i, n) for n, i, _, _ in HAND_MADE] + [(4, "d.png"), (5, "e.png"), (6, "f.png")]
    scene = _build([largest, other], images, tmp_path, fov_by_image={6: 55.0})
    by_name = {c.name: c for c in scene.cameras}
    ranges = [by_name[n].range for n in ("a.png", "b.png", "c.png")]
    assert by_name["d.png"].registered
    assert by_name["d.png"].range == pytest.approx(np.median(ranges))  # it observes no point
    e, f = by_name["e.png"], by_name["f.png"]
    assert (e.registered, e.model, f.registered, f.model) == (False, 1, False, None)
    for camera in (e, f):
        assert (camera.x, camera.y, camera.yaw_deg, camera.center, camera.qvec) == (None,) * 5
        assert camera.range == pytest.approx(np.median(ranges + [by_name["d.png"].range]))
    assert f.fov_deg == 55.0
    assert scene.models == [{"index": 0, "num_images": 4}, {"index": 1, "num_images": 1}]


@pytest.fixture(scope="module")
def synthetic():
    pycolmap.set_random_seed(0)
    options = pycolmap.SyntheticDatasetOptions(num_points3D=300)
    return pycolmap.synthesize_dataset(options)


def test_synthetic_scene_matches_the_contract(synthetic, tmp_path):
    images = sorted(((i, im.name) for i, im in synthetic.images.items()), key=lambda t: -t[0])
    scene = _build([synthetic], images, tmp_path, max_points=120)
    data = scene.to_dict()
    assert set(data) >= {"frame", "cameras", "points", "models"}
    assert set(data["frame"]) == {"origin", "x_axis", "y_axis", "up"}
    assert set(data["cameras"][0]) == {"image_id", "name", "seq", "registered", "model", "x", "y",
                                       "yaw_deg", "fov_deg", "range", "center", "qvec",
                                       "group_pose"}  # null in the largest model (v1.1)
    assert all(c["group_pose"] is None for c in data["cameras"])
    assert [c["name"] for c in data["cameras"]] == sorted(name for _, name in images)
    assert len(data["points"]["xy"]) == 120
    frame = scene.frame
    np.testing.assert_allclose(np.cross(frame.x_axis, frame.y_axis), frame.up, atol=1e-9)
    for camera in scene.cameras:  # positions and yaws: test_synthetic_scene_against_the_model_alone
        image = synthetic.images[camera.image_id]
        observed = np.array([synthetic.points3D[p.point3D_id].xyz
                           for p in image.get_observation_points2D()])
        depths = (observed @ image.cam_from_world().rotation.matrix().T
                  + image.cam_from_world().translation)[:, 2]
        assert camera.range == pytest.approx(np.median(depths))


def test_synthetic_scene_against_the_model_alone(synthetic, tmp_path):
    """Expected values from the model's poses and points by the test's own maths, not from the
    scene's frame (only its up is taken, after checking it is a ground the contract allows): the
    2D map is the camera centres seen from above, so distances and turns between cameras match."""
    scene = _build([synthetic], [(i, im.name) for i, im in synthetic.images.items()], tmp_path)
    rotations = {im.name: im.cam_from_world().rotation.matrix() for im in synthetic.images.values()}
    centers = {im.name: im.projection_center() for im in synthetic.images.values()}
    cameras_up = sum(-r[1] for r in rotations.values())  # a camera's up is minus its y (y points down)
    up = scene.frame.up
    assert np.linalg.norm(up) == pytest.approx(1.0)
    assert up @ cameras_up / np.linalg.norm(cameras_up) >= np.cos(np.radians(30.0))
    points = np.array([p.xyz for p in synthetic.points3D.values()])
    heights = (points - scene.frame.origin) @ up
    assert np.mean(np.abs(heights) < 0.035) >= 0.05  # a band of 1% of the cube's 3.5 diagonal
    centroid = np.mean(list(centers.values()), axis=0)
    assert np.linalg.norm(np.cross(scene.frame.origin - centroid, up)) < 1e-9  # below the centroid

    def flat(v):
        return v - (v @ up) * up

    for a in scene.cameras:
        for b in scene.cameras:
            ground = np.linalg.norm(flat(centers[a.name] - centers[b.name]))
            assert np.hypot(a.x - b.x, a.y - b.y) == pytest.approx(ground, abs=1e-9)
            # the turn from b's heading to a's, counter-clockwise seen from above (about up)
            ha, hb = flat(rotations[a.name][2]), flat(rotations[b.name][2])
            turn = np.degrees(np.arctan2(np.cross(hb, ha) @ up, hb @ ha))
            assert geometry.wrap_deg(a.yaw_deg - b.yaw_deg - turn) == pytest.approx(0.0, abs=1e-6)


def test_synthetic_scene_is_deterministic(synthetic, tmp_path):
    images = [(i, im.name) for i, im in synthetic.images.items()]
    a = _build([synthetic], images, tmp_path, max_points=50, seed=3).to_dict()
    b = _build([synthetic], images, tmp_path, max_points=50, seed=3).to_dict()
    assert a == b


def test_no_model_is_an_error(tmp_path):
    with pytest.raises(EmptyModel):
        _build([], [(1, "a.png")], tmp_path)
