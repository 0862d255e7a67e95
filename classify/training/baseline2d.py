"""The paper's baseline: a small 2D CNN that names an object from one sonar image.

Input: one image per sample, ``(H, W)`` (range bins x beams), any dtype; it is scaled to [0, 1]
(uint8 / 255, float as is) and kept at its own size (global average pooling at the end).
Network: four ``conv3x3 -> BN -> ReLU -> maxpool2`` stages (16-32-64-64 channels times ``width``),
global average pool, dropout, linear. Training mirrors :func:`classify.training.train.train`: stratified
validation split, Adam + one-cycle schedule, early stopping on validation accuracy, seeded.
Augmentation: random shifts in range and beam (the object's place in the image is not a cue).
"""

from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import torch
from torch import Tensor, nn

from auvlink.progress import progress_bar
from classify.pointnet import default_device
from classify.training.dataset import stratified_split


@dataclass(frozen=True)
class ImageSet:
    images: npt.NDArray[Any]  # (M, H, W)
    labels: npt.NDArray[np.int64]
    class_names: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.labels)

    def subset(self, idx: npt.NDArray[np.integer[Any]]) -> ImageSet:
        return ImageSet(self.images[idx], self.labels[idx], self.class_names)


@dataclass(frozen=True)
class CNNConfig:
    epochs: int = 30
    batch_size: int = 32
    lr: float = 2e-3
    weight_decay: float = 1e-4
    width: float = 1.0
    dropout: float = 0.3
    patience: int = 10
    val_fraction: float = 0.2
    max_shift: int = 8
    seed: int = 0
    threads: int = 2

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class SmallCNN(nn.Module):
    def __init__(self, num_classes: int, width: float = 1.0, dropout: float = 0.3) -> None:
        super().__init__()
        chans = [max(4, round(c * width)) for c in (16, 32, 64, 64)]
        layers: list[nn.Module] = []
        c_in = 1
        for c in chans:
            layers += [nn.Conv2d(c_in, c, 3, padding=1, bias=False), nn.BatchNorm2d(c), nn.ReLU(inplace=True),
                       nn.MaxPool2d(2)]
            c_in = c
        self.features = nn.Sequential(*layers)
        self.dropout = nn.Dropout(dropout)
        self.fc = nn.Linear(c_in, num_classes)

    def forward(self, x: Tensor) -> Tensor:
        if x.ndim == 3:
            x = x[:, None]
        return self.fc(self.dropout(self.features(x).mean(dim=(2, 3))))


def to_float(images: npt.NDArray[Any]) -> npt.NDArray[np.float32]:
    """Images scaled to [0, 1] float32 (uint8 divided by 255)."""
    if images.dtype == np.uint8:
        return images.astype(np.float32) / 255.0
    return images.astype(np.float32)


def random_shift(images: npt.NDArray[np.float32], rng: np.random.Generator, max_shift: int) -> npt.NDArray[np.float32]:
    """Each image rolled by up to ``max_shift`` pixels along both axes (zero fill)."""
    if max_shift <= 0:
        return images
    out = np.zeros_like(images)
    h, w = images.shape[1:]
    for i, (dy, dx) in enumerate(rng.integers(-max_shift, max_shift + 1, size=(len(images), 2))):
        ys, yd = (slice(0, h - dy), slice(dy, h)) if dy >= 0 else (slice(-dy, h), slice(0, h + dy))
        xs, xd = (slice(0, w - dx), slice(dx, w)) if dx >= 0 else (slice(-dx, w), slice(0, w + dx))
        out[i, yd, xd] = images[i, ys, xs]
    return out


@torch.no_grad()
def predict_cnn(model: SmallCNN, images: npt.NDArray[Any], batch_size: int = 64) -> npt.NDArray[np.float32]:
    """Logits ``(M, k)``."""
    device = next(model.parameters()).device
    model.eval()
    x = to_float(images)
    out = [model(torch.from_numpy(x[i:i + batch_size]).to(device)).cpu().numpy()
           for i in range(0, len(x), batch_size)]
    return np.concatenate(out) if out else np.zeros((0, model.fc.out_features), np.float32)


@dataclass
class CNNResult:
    model: SmallCNN
    history: list[dict[str, float]]
    best_epoch: int
    val_accuracy: float
    seconds: float


def train_cnn(data: ImageSet, cfg: CNNConfig, progress: bool = True,
              device: torch.device | None = None) -> CNNResult:
    if cfg.threads > 0:
        torch.set_num_threads(cfg.threads)
    device = device or default_device()
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    tr_idx, va_idx = stratified_split(data.labels, cfg.val_fraction, rng)
    model = SmallCNN(len(data.class_names), cfg.width, cfg.dropout).to(device)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    steps = max(1, int(np.ceil(len(tr_idx) / cfg.batch_size)))
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=cfg.lr, epochs=cfg.epochs, steps_per_epoch=steps,
                                                pct_start=0.15)
    images = to_float(data.images)
    best_acc, best_epoch, since, best_state = -1.0, 0, 0, copy.deepcopy(model.state_dict())
    history: list[dict[str, float]] = []
    t0 = time.perf_counter()
    for epoch in progress_bar(range(cfg.epochs), enabled=progress, desc="train 2D CNN"):
        model.train()
        order = tr_idx[rng.permutation(len(tr_idx))]
        for s in range(0, len(order), cfg.batch_size):
            batch = order[s:s + cfg.batch_size]
            if len(batch) < 2:
                continue
            x = torch.from_numpy(random_shift(images[batch], rng, cfg.max_shift)).to(device)
            y = torch.from_numpy(data.labels[batch]).to(device)
            loss = nn.functional.cross_entropy(model(x), y)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
        va = data.labels[va_idx]
        acc = float((predict_cnn(model, data.images[va_idx]).argmax(1) == va).mean()) if len(va) else 0.0
        history.append({"epoch": epoch + 1, "val_acc": acc, "seconds": time.perf_counter() - t0})
        if acc > best_acc:
            best_acc, best_epoch, since, best_state = acc, epoch + 1, 0, copy.deepcopy(model.state_dict())
        else:
            since += 1
            if since >= cfg.patience:
                break
    model.load_state_dict(best_state)
    model.eval()
    return CNNResult(model, history, best_epoch, best_acc, time.perf_counter() - t0)
