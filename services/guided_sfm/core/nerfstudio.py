"""A COLMAP model in nerfstudio's own data format: transforms.json and sparse_pc.ply.

What nerfstudio's `colmap_utils.colmap_to_json` writes and its `nerfstudio` dataparser reads:
per frame a camera-to-world matrix in its OpenGL camera convention (x right, y up, looking down
-z), in a world whose axes are COLMAP's turned by `applied_transform` (y and z swapped, z negated);
OPENCV intrinsics (fl_x, fl_y, cx, cy, k1, k2, p1, p2) in COLMAP's pixel convention.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pycolmap

# nerfstudio's applied_transform: eye(4)[:3][[0, 2, 1]] with the last row negated
APPLIED = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0]])
DISTORTION = ("k1", "k2", "p1", "p2")


def intrinsics(camera: pycolmap.Camera) -> dict:
    """The camera as nerfstudio's OPENCV model (pinhole and radial COLMAP models map onto it)."""
    params, name = [float(p) for p in camera.params], camera.model_name
    if name in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"):
        fx = fy = params[0]
        cx, cy = params[1], params[2]
        extra = params[3:] + [0.0] * (4 - len(params[3:]))
    elif name in ("PINHOLE", "OPENCV"):
        fx, fy, cx, cy = params[:4]
        extra = params[4:8] + [0.0] * (4 - len(params[4:8]))
    else:
        raise ValueError(f"camera model {name} has no nerfstudio equivalent here")
    return {"camera_model": "OPENCV", "fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy,
            "w": int(camera.width), "h": int(camera.height), **dict(zip(DISTORTION, extra, strict=True))}


def transform_matrix(image: pycolmap.Image) -> list[list[float]]:
    """The image's camera-to-world matrix as nerfstudio stores it (OpenGL camera, turned world)."""
    world_from_cam = np.eye(4)
    world_from_cam[:3, :] = image.cam_from_world().inverse().matrix()
    world_from_cam[0:3, 1:3] *= -1  # OpenCV camera axes (y down, z forward) -> OpenGL
    world_from_cam = world_from_cam[[0, 2, 1, 3], :]
    world_from_cam[2, :] *= -1
    return world_from_cam.tolist()


def transforms(model: pycolmap.Reconstruction, image_dir: str = "images") -> dict:
    """transforms.json for every registered image of the model, in name order."""
    frames = []
    for image in sorted(model.images.values(), key=lambda i: i.name):
        if not image.has_pose:
            continue
        frames.append({"file_path": f"{image_dir}/{image.name}", "transform_matrix": transform_matrix(image),
                       "colmap_im_id": int(image.image_id), **intrinsics(image.camera)})
    cameras = {json_key(f) for f in frames}
    shared = frames[0] if len(cameras) == 1 and frames else {}
    top = {k: shared[k] for k in ("camera_model", "fl_x", "fl_y", "cx", "cy", "w", "h", *DISTORTION)
           if k in shared}
    return {**top, "frames": frames, "applied_transform": APPLIED.tolist(), "ply_file_path": "sparse_pc.ply"}


def json_key(frame: dict) -> tuple:
    return tuple(frame[k] for k in ("fl_x", "fl_y", "cx", "cy", "w", "h", *DISTORTION))


def write_points_ply(model: pycolmap.Reconstruction, out_file: Path) -> int:
    """The model's points (turned by APPLIED, as nerfstudio's own export does) with colours, as a
    binary PLY in point-id order; returns how many."""
    ids = sorted(model.points3D)
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(ids)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n")
    with open(out_file, "wb") as handle:
        handle.write(header.encode())
        for point_id in ids:
            point = model.points3D[point_id]
            x, y, z = APPLIED[:, :3] @ np.asarray(point.xyz) + APPLIED[:, 3]
            handle.write(struct.pack("<fffBBB", x, y, z, *(int(c) for c in point.color)))
    return len(ids)
