"""Seedlings graded from pictures: seed 002's recognition pipeline (Zhao et al. 2022) in OpenCV.

    grading   the paper's rule for one cell and the class vocabulary (pure Python)
    pipeline  grade_tray: picture -> tilt correction -> frame -> cell grid by projection
              profiles -> leaves by HSV -> per-cell area, centroid, secants -> classes
    overlay   the grid and the classes drawn on the rectified picture
    metrics   confusion matrix, accuracy with its Wilson interval, leaf-area error

Imports OpenCV (cv2) and numpy, never MuJoCo: the picture may come from the twin's camera
(`transplanter.scene.tray_camera`) or from a real one.
"""

from transplanter.vision.grading import CLASSES, GradingRule, grade
from transplanter.vision.pipeline import (
    CameraMount,
    GridNotFound,
    ImageUnusable,
    TrayLayout,
    TrayNotFound,
    VisionThresholds,
    grade_tray,
)

__all__ = [
    "CLASSES",
    "CameraMount",
    "GradingRule",
    "GridNotFound",
    "ImageUnusable",
    "TrayLayout",
    "TrayNotFound",
    "VisionThresholds",
    "grade",
    "grade_tray",
]
