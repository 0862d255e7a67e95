"""Training of :class:`~classify.pointnet.PointNet` on a :class:`~classify.training.dataset.CloudSet`.

Adam with a one-cycle (cosine) learning-rate schedule, cross entropy (label smoothing) plus the feature
transform's orthogonality regulariser, a stratified validation split, early stopping on the
validation accuracy (ties broken by the validation loss) with the best weights restored, and a
tqdm progress bar. Each epoch sees every training cloud once, subsampled to ``n_points`` points,
rescaled into the unit sphere (as :class:`classify.infer.Classifier` does) and augmented
(:mod:`classify.training.augment`); every draw comes from one generator seeded by ``seed``.
"""

from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import torch
from torch import nn

from auvlink.progress import progress_bar
from classify.labels import CLUTTER
from classify.pointnet import PointNet, PointNetConfig, default_device, orthogonality_loss
from classify.training.augment import AugmentConfig, augment_batch, normalize_batch
from classify.training.dataset import CloudSet, stratified_split


@dataclass(frozen=True)
class TrainConfig:
    epochs: int = 60
    batch_size: int = 32
    lr: float = 2e-3
    weight_decay: float = 1e-4
    label_smoothing: float = 0.05
    reg_weight: float = 1e-3
    patience: int = 20
    val_fraction: float = 0.2
    n_points: int = 512
    width: float = 0.5
    dropout: float = 0.3
    seed: int = 0
    threads: int = 2
    members: int = 1  # models trained from seeds seed, seed + 1, ...; inference averages them (classify.ensemble)
    augment: AugmentConfig = field(default_factory=AugmentConfig)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TrainConfig:
        kw = {k: d[k] for k in cls.__dataclass_fields__ if k in d and k != "augment"}
        if "augment" in d:
            kw["augment"] = AugmentConfig.from_dict(d["augment"])
        return cls(**kw)


@dataclass
class TrainResult:
    model: PointNet
    history: list[dict[str, float]]
    best_epoch: int
    val_accuracy: float
    seconds: float
    train_idx: npt.NDArray[np.int64]
    val_idx: npt.NDArray[np.int64]


def subsample(points: npt.NDArray[np.float32], n: int, rng: np.random.Generator) -> npt.NDArray[np.float32]:
    """``n`` points of each cloud in a batch ``(B, N, 3)`` (without replacement where ``N >= n``)."""
    b, big_n, _ = points.shape
    if big_n == n:
        return points
    if big_n > n:
        idx = np.argsort(rng.random((b, big_n)), axis=1)[:, :n]
    else:
        idx = rng.integers(0, big_n, size=(b, n))
    return np.take_along_axis(points, idx[:, :, None], axis=1)


@torch.no_grad()
def predict_logits(model: PointNet, points: npt.NDArray[np.float32], batch_size: int = 64,
                   device: torch.device | None = None) -> npt.NDArray[np.float32]:
    """Logits ``(M, k)`` for clouds ``(M, N, 3)`` (model switched to eval mode)."""
    device = device or next(model.parameters()).device
    model.eval()
    out = []
    for i in range(0, len(points), batch_size):
        x = torch.from_numpy(np.ascontiguousarray(points[i:i + batch_size])).to(device)
        out.append(model(x)[0].float().cpu().numpy())
    return np.concatenate(out) if out else np.zeros((0, model.cfg.num_classes), np.float32)


def _val(model: PointNet, pts: npt.NDArray[np.float32], labels: npt.NDArray[np.int64],
         device: torch.device) -> tuple[float, float]:
    if len(labels) == 0:
        return float("nan"), float("nan")
    logits = torch.from_numpy(predict_logits(model, pts, device=device))
    loss = nn.functional.cross_entropy(logits, torch.from_numpy(labels)).item()
    acc = float((logits.argmax(1).numpy() == labels).mean())
    return acc, loss



@dataclass(frozen=True)
class _Augmenting:
    """What the augmentation of one training batch needs besides the batch: the normalisation (fixed scale,
    seabed-referenced z), the clutter pool and the clutter label."""

    fixed: bool
    keep_z: bool
    pool: npt.NDArray[np.float32] | None
    clutter_label: int


def _train_epoch(model: PointNet, opt: torch.optim.Optimizer, sched: torch.optim.lr_scheduler.LRScheduler,
                 data: CloudSet, cfg: TrainConfig, order: npt.NDArray[np.int64], aug: _Augmenting,
                 rng: np.random.Generator, device: torch.device) -> tuple[float, int, int]:
    """One pass over the training clouds in ``order``: (summed loss, correct, clouds seen)."""
    tot_loss, tot_ok, seen = 0.0, 0, 0
    for s in range(0, len(order), cfg.batch_size):
        batch = order[s:s + cfg.batch_size]
        if len(batch) < 2:  # batch norm needs two samples
            continue
        pts = normalize_batch(subsample(data.points[batch], cfg.n_points, rng), aug.fixed, aug.keep_z)
        pts = augment_batch(pts, rng, cfg.augment, aug.fixed, aug.keep_z, aug.pool,
                            data.labels[batch] != aug.clutter_label,
                            None if data.measured is None else data.measured[batch])
        x = torch.from_numpy(pts).to(device)
        y = torch.from_numpy(data.labels[batch]).to(device)
        logits, trans = model(x)
        loss = nn.functional.cross_entropy(logits, y, label_smoothing=cfg.label_smoothing)
        if trans is not None and cfg.reg_weight > 0:
            loss = loss + cfg.reg_weight * orthogonality_loss(trans)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        sched.step()
        tot_loss += loss.item() * len(batch)
        tot_ok += int((logits.argmax(1) == y).sum().item())
        seen += len(batch)
    return tot_loss, tot_ok, seen


def train(data: CloudSet, cfg: TrainConfig, progress: bool = True,
          device: torch.device | None = None, init: PointNet | None = None) -> TrainResult:
    """Train a PointNet on ``data``; returns the best model (by validation accuracy). ``init``: start from a copy of
    this network's weights (same classes, as ``data``'s) instead of a new one."""
    if cfg.threads > 0:
        torch.set_num_threads(cfg.threads)
    device = device or default_device()
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    tr_idx, va_idx = stratified_split(data.labels, cfg.val_fraction, rng)
    if init is not None and init.cfg.num_classes != len(data.class_names):
        raise ValueError(f"the network to start from has {init.cfg.num_classes} outputs, the clouds "
                         f"{len(data.class_names)} classes")
    model = copy.deepcopy(init).to(device) if init is not None else \
        PointNet(PointNetConfig(num_classes=len(data.class_names), width=cfg.width, dropout=cfg.dropout)).to(device)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    steps_per_epoch = max(1, int(np.ceil(len(tr_idx) / cfg.batch_size)))
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=cfg.lr, epochs=cfg.epochs,
                                                steps_per_epoch=steps_per_epoch, pct_start=0.15)
    # validation clouds: a fixed subsample (no augmentation)
    fixed = data.scale_m > 0
    keep_z = fixed and data.z_ref == "seabed"
    va_pts = normalize_batch(subsample(data.points[va_idx], cfg.n_points, np.random.default_rng(cfg.seed + 1)),
                             fixed, keep_z)
    va_lab = data.labels[va_idx]
    # clutter clouds of the training split: attached to object clouds by the augmentation (attach_prob)
    clutter_label = data.class_names.index(CLUTTER) if CLUTTER in data.class_names else -1
    pool_idx = tr_idx[data.labels[tr_idx] == clutter_label]
    pool = normalize_batch(subsample(data.points[pool_idx], cfg.n_points, np.random.default_rng(cfg.seed + 2)),
                           fixed, keep_z) if pool_idx.size else None
    history: list[dict[str, float]] = []
    best: tuple[float, float] = (-1.0, float("inf"))
    best_state, best_epoch, since_best = copy.deepcopy(model.state_dict()), 0, 0
    t0 = time.perf_counter()
    bar = progress_bar(range(cfg.epochs), enabled=progress, desc="train", leave=True)
    for epoch in bar:
        model.train()
        order = tr_idx[rng.permutation(len(tr_idx))]
        augmenting = _Augmenting(fixed, keep_z, pool, clutter_label)
        tot_loss, tot_ok, seen = _train_epoch(model, opt, sched, data, cfg, order, augmenting, rng, device)
        va_acc, va_loss = _val(model, va_pts, va_lab, device)
        row = {"epoch": epoch + 1, "train_loss": tot_loss / max(seen, 1), "train_acc": tot_ok / max(seen, 1),
               "val_loss": va_loss, "val_acc": va_acc, "lr": sched.get_last_lr()[0],
               "seconds": time.perf_counter() - t0}
        history.append(row)
        bar.set_postfix(loss=f"{row['train_loss']:.3f}", acc=f"{row['train_acc']:.3f}", val=f"{va_acc:.3f}")
        key = (va_acc, -va_loss) if len(va_lab) else (row["train_acc"], -row["train_loss"])
        if key > (best[0], -best[1]):
            best, best_epoch, since_best = (key[0], -key[1]), epoch + 1, 0
            best_state = copy.deepcopy(model.state_dict())
        else:
            since_best += 1
            if since_best >= cfg.patience:
                break
    model.load_state_dict(best_state)
    model.eval()
    return TrainResult(model, history, best_epoch, best[0], time.perf_counter() - t0, tr_idx, va_idx)
