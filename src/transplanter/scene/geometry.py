"""Procedural geometry of the scene: the drop tube's walls,
the conveyor's cells, ribs and belt table, the gripper column and the pots' inertia.

Pure functions of a SceneConfig (numpy/math only, no MjSpec): build_scene and
scripts/make_models.py both call them, so the models' XML and a built scene agree bit for bit.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from transplanter.scene.config import (
    BRIDGE_THICKNESS,
    JAW_HALF_HEIGHT,
    WRIST_SERVO_BOTTOM,
    SceneConfig,
)

Box = tuple[np.ndarray, np.ndarray, np.ndarray]  # half sizes, pos, quat


def ring_boxes(
    radius_top: float,
    z_top: float,
    radius_bottom: float,
    z_bottom: float,
    wall: float,
    segments: int,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Convex boxes (half sizes, pos, quat) forming a conical/cylindrical wall of revolution.

    The inner faces lie on the surface from (radius_top, z_top) to (radius_bottom,
    z_bottom); boxes overlap slightly so nothing slips through the seams.
    """
    dr, dz = radius_bottom - radius_top, z_bottom - z_top
    slant = math.hypot(dr, dz)
    boxes = []
    half_width = (max(radius_top, radius_bottom) + wall) * math.tan(math.pi / segments) * 1.05
    for k in range(segments):
        a = 2 * math.pi * k / segments
        e_r = np.array([math.cos(a), math.sin(a), 0.0])
        e_t = np.array([-math.sin(a), math.cos(a), 0.0])
        e_z = np.array([0.0, 0.0, 1.0])
        up_slant = -(dr * e_r + dz * e_z) / slant
        normal = (-dz * e_r + dr * e_z) / slant
        mid = ((radius_top + radius_bottom) / 2) * e_r + ((z_top + z_bottom) / 2) * e_z
        pos = mid + normal * wall / 2
        rot = np.column_stack([normal, e_t, up_slant])
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, rot.flatten())
        boxes.append((np.array([wall / 2, half_width, slant / 2]), pos, quat))
    return boxes


def drop_tube_boxes(config: SceneConfig) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Funnel and tube collision boxes in the drop_tube body frame (origin at the funnel top)."""
    r_top = config.funnel_top_diameter_m / 2
    r_throat = config.funnel_throat_diameter_m / 2
    funnel = ring_boxes(
        r_top, 0.0, r_throat, -config.funnel_height_m, config.tube_wall_m, config.tube_segments
    )
    z_throat = -config.funnel_height_m
    tube = ring_boxes(
        r_throat,
        z_throat,
        r_throat,
        z_throat - config.tube_length_m,
        config.tube_wall_m,
        config.tube_segments,
    )
    return funnel + tube


def pot_inertia(mass: float, radius: float, height: float) -> np.ndarray:
    """Principal inertia (kg*m^2) of a solid cylinder about its centre, axis along z."""
    ixx = mass * (3 * radius**2 + height**2) / 12
    return np.array([ixx, ixx, mass * radius**2 / 2])


def crook_frame(
    crook: float, azimuth: float, height: float, foot: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A crooked pot's wall in its body frame (origin at the pot's centre): the pivot at the
    top of its flat foot, the rotation (3x3) and quaternion (w, x, y, z) that lean the wall
    by `crook` (rad) towards `azimuth` (rad from +x). A point p of the straight pot above
    the foot sits at pivot + R (p - pivot) on the crooked one."""
    u = np.array([-np.sin(azimuth), np.cos(azimuth), 0.0])  # z x (cos az, sin az, 0)
    cross = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    rot = np.eye(3) * np.cos(crook) + np.sin(crook) * cross + (1 - np.cos(crook)) * np.outer(u, u)
    quat = np.concatenate([[np.cos(crook / 2)], np.sin(crook / 2) * u])
    pivot = np.array([0.0, 0.0, -height / 2 + foot])
    return pivot, rot, quat


def cell_columns_x(config: SceneConfig) -> np.ndarray:
    """x (m) of the centres of the cols cells of a row, symmetric about x = 0."""
    return (np.arange(config.cols) - (config.cols - 1) / 2) * config.cell_pitch_m


def row_y(config: SceneConfig) -> np.ndarray:
    """y (m) of the centres of the rows at conveyor position 0 (row 0 is the pickup row)."""
    return config.pickup_row_y_m + np.arange(config.rows) * config.row_pitch_m


def cell_centres(config: SceneConfig) -> np.ndarray:
    """(rows*cols, 2) xy (m) of every cell centre at conveyor position 0, row-major."""
    xs, ys = cell_columns_x(config), row_y(config)
    return np.array([[xs[c], ys[r]] for r in range(config.rows) for c in range(config.cols)])


def belt_table(config: SceneConfig, half_thickness: float) -> tuple[list, list]:
    """Size (half sizes) and pos of the static belt table box: from the front edge of the
    pickup row to one row pitch behind the last row, table_side_margin_m wider than the ribs;
    its top face is the belt top (z = 0)."""
    half_width = config.cols * config.cell_pitch_m / 2
    front = config.pickup_row_y_m - config.row_pitch_m / 2
    back = row_y(config)[-1] + config.row_pitch_m
    size = [half_width + config.table_side_margin_m, (back - front) / 2, half_thickness]
    pos = [0, (front + back) / 2, -half_thickness]
    return size, pos


def rib_boxes(config: SceneConfig, row: int) -> list[tuple[list, list]]:
    """(half sizes, pos) of the ribs of one conveyor row in the carriage frame: the two cross
    ribs at +-row_pitch_m/2 from the row's centre line, then the cols + 1 ribs between cells."""
    half_width = config.cols * config.cell_pitch_m / 2
    y = row_y(config)[row]
    rib_half_h = config.rib_height_m / 2
    rib_half_t = config.rib_thickness_m / 2
    ribs = [
        ([half_width, rib_half_t, rib_half_h], [0, y + side * config.row_pitch_m / 2, rib_half_h])
        for side in (-1, 1)
    ]
    ribs += [
        ([rib_half_t, config.row_pitch_m / 2, rib_half_h], [x, y, rib_half_h])
        for x in (np.arange(config.cols + 1) - config.cols / 2) * config.cell_pitch_m
    ]
    return ribs


def column_box(config: SceneConfig) -> tuple[float, float]:
    """Half length and centre z (m, gripper frame, C at 0) of the gripper's column: from
    just under the wrist servo down to the top of the palm (the bridge)."""
    column_top = -WRIST_SERVO_BOTTOM
    column_bottom = -(config.column_height_m - config.bridge_clearance_m - BRIDGE_THICKNESS)
    if column_bottom >= column_top:
        raise ValueError("SceneConfig.column_height_m too small for the wrist servo and palm")
    return (column_top - column_bottom) / 2, (column_top + column_bottom) / 2


def bridge_box(config: SceneConfig) -> tuple[float, float]:
    """Half height and centre z (m, gripper frame, C at 0) of the palm: the bridge plate whose
    underside sits bridge_clearance_m above the grip centre."""
    bottom = -config.column_height_m + config.bridge_clearance_m
    return BRIDGE_THICKNESS / 2, bottom + BRIDGE_THICKNESS / 2


def side_plate_box(config: SceneConfig) -> tuple[float, float]:
    """Half height and centre z (m, jaw frame: the grip centre's height) of a jaw's side
    plate, from the jaw's top edge up to the bridge's underside."""
    half = (config.bridge_clearance_m - JAW_HALF_HEIGHT) / 2
    return half, JAW_HALF_HEIGHT + half
