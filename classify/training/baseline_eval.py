"""Train and evaluate the 2D single-image baseline on simulated sonar images of the catalog."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from classify.training.baseline2d import CNNConfig, CNNResult, predict_cnn, train_cnn
from classify.training.baseline_images import ImageSettings, heldout_image_settings, render_images
from classify.training.evaluate import EvalReport


@dataclass
class BaselineOutcome:
    result: CNNResult
    report: EvalReport
    render_seconds: float
    n_train: int


def run_baseline2d(class_names: tuple[str, ...], images: ImageSettings, cnn: CNNConfig,
                   cache_dir: Path | None = None, progress: bool = False) -> BaselineOutcome:
    """Render training and held-out images, train the CNN, evaluate on the held-out images."""
    t0 = time.perf_counter()
    train_set = render_images(class_names, images, progress, cache_dir)
    test_set = render_images(class_names, heldout_image_settings(images), progress, cache_dir)
    t_render = time.perf_counter() - t0
    result = train_cnn(train_set, cnn, progress)
    pred = predict_cnn(result.model, test_set.images).argmax(axis=1)
    return BaselineOutcome(result, EvalReport.from_predictions(class_names, test_set.labels, pred), t_render,
                           len(train_set))
