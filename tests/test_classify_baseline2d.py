"""The 2D single-image baseline: CNN shapes, a toy training run, shifts, simulated images."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from classify.training.baseline2d import CNNConfig, ImageSet, SmallCNN, predict_cnn, random_shift, train_cnn

torch.set_num_threads(1)


def test_cnn_shapes_any_image_size() -> None:
    model = SmallCNN(8, width=0.5).eval()
    assert model(torch.rand(2, 128, 96)).shape == (2, 8)
    assert model(torch.rand(3, 1, 64, 48)).shape == (3, 8)


def test_random_shift_moves_content_and_is_seeded() -> None:
    img = np.zeros((4, 20, 10), np.float32)
    img[:, 10, 5] = 1.0
    a = random_shift(img, np.random.default_rng(0), 3)
    b = random_shift(img, np.random.default_rng(0), 3)
    assert np.array_equal(a, b) and a.shape == img.shape
    assert np.all(a.sum(axis=(1, 2)) == 1.0)
    assert random_shift(img, np.random.default_rng(0), 0) is img


@pytest.mark.train
def test_toy_training_beats_chance() -> None:
    rng = np.random.default_rng(0)
    n = 60
    labels = np.arange(n) % 3
    images = rng.integers(0, 60, size=(n, 32, 24)).astype(np.uint8)
    for i, c in enumerate(labels):  # class = which third of the range holds a bright blob
        r = 4 + 10 * c + int(rng.integers(0, 4))
        images[i, r:r + 3, 8:16] = 250
    data = ImageSet(images, labels.astype(np.int64), ("near", "mid", "far"))
    res = train_cnn(data, CNNConfig(epochs=12, batch_size=12, lr=5e-3, width=0.5, max_shift=1, threads=1),
                    progress=False, device=torch.device("cpu"))
    acc = float((predict_cnn(res.model, images).argmax(1) == labels).mean())
    assert acc >= 0.7  # chance 1/3


def test_rendered_images_shape_and_determinism() -> None:
    pytest.importorskip("auvlink.sim.sonar_render")
    from classify.training.baseline_images import ImageSettings, heldout_image_settings, render_images

    s = ImageSettings(headings_deg=(30.0,), tilts_deg=(30.0,))
    a = render_images(("box",), s)
    b = render_images(("box",), s)
    assert a.images.shape == (1, 128, 96) and a.images.dtype == np.float32
    assert np.array_equal(a.images, b.images)
    assert 0.0 <= a.images.min() and a.images.max() <= 1.0
    held = heldout_image_settings(ImageSettings())
    assert set(held.headings_deg).isdisjoint(ImageSettings().headings_deg)
