"""The pipeline measured against the truth: confusion matrix, accuracy with its 95 % Wilson
interval, leaf-area error. Takes class lists and numbers, not trays: no MuJoCo here."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from transplanter.vision.grading import CLASSES, EMPTY

Z95 = 1.959963984540054


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """95 % Wilson score interval of a binomial proportion (as transplanter.twin.results'; kept
    here so that the vision package imports nothing of the twin)."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


def confusion(truth: Sequence[str], predicted: Sequence[str]) -> np.ndarray:
    """(5, 5) counts, rows the true class, columns the predicted one, in CLASSES order."""
    if len(truth) != len(predicted):
        raise ValueError(f"{len(truth)} true classes but {len(predicted)} predicted")
    index = {c: i for i, c in enumerate(CLASSES)}
    out = np.zeros((len(CLASSES), len(CLASSES)), dtype=int)
    for t, p in zip(truth, predicted, strict=True):
        out[index[t], index[p]] += 1
    return out


@dataclass(frozen=True)
class Score:
    """Accuracy over cells, its Wilson interval, the confusion matrix, and the leaf-area error
    (measured - true, mm^2) over cells that hold a seedling and were not graded empty."""

    correct: int
    cells: int
    interval: tuple[float, float]
    matrix: np.ndarray
    area_error_mean_mm2: float
    area_error_abs_mm2: float

    @property
    def accuracy(self) -> float:
        return self.correct / self.cells if self.cells else float("nan")

    def as_dict(self) -> dict:
        return {
            "correct": self.correct,
            "cells": self.cells,
            "accuracy": round(self.accuracy, 6),
            "wilson_95": [round(v, 6) for v in self.interval],
            "classes": list(CLASSES),
            "confusion_truth_rows": self.matrix.tolist(),
            "area_error_mean_mm2": round(self.area_error_mean_mm2, 3),
            "area_error_abs_mm2": round(self.area_error_abs_mm2, 3),
        }


def score(
    truth: Sequence[str],
    predicted: Sequence[str],
    true_area_mm2: Sequence[float],
    measured_area_mm2: Sequence[float],
) -> Score:
    """Score one tray or several pooled (the sequences concatenated)."""
    matrix = confusion(truth, predicted)
    correct = int(np.trace(matrix))
    n = int(matrix.sum())
    both = [
        m - a
        for t, p, a, m in zip(truth, predicted, true_area_mm2, measured_area_mm2, strict=True)
        if t != EMPTY and p != EMPTY
    ]
    err = np.array(both, dtype=float)
    return Score(
        correct=correct,
        cells=n,
        interval=wilson_interval(correct, n),
        matrix=matrix,
        area_error_mean_mm2=float(err.mean()) if err.size else float("nan"),
        area_error_abs_mm2=float(np.abs(err).mean()) if err.size else float("nan"),
    )


def format_matrix(matrix: np.ndarray) -> str:
    """The confusion matrix as a Markdown table (rows: truth, columns: predicted)."""
    head = "| truth \\ graded | " + " | ".join(CLASSES) + " |"
    rule = "| --- |" + " --- |" * len(CLASSES)
    rows = [
        f"| {c} | " + " | ".join(str(v) for v in matrix[i]) + " |" for i, c in enumerate(CLASSES)
    ]
    return "\n".join([head, rule, *rows])
