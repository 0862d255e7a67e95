"""Evaluation of a classifier: per-class precision, recall and F1, the confusion matrix (and a PNG of
it), and the confusions between the look-alike pairs sphere/hemisphere and pipe/half_pipe.

Precision of class c = correct c / predicted c; recall = correct c / true c; F1 their harmonic
mean (0 where undefined). Macro averages weight every class alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.atomic import atomic_path

LOOKALIKE_PAIRS: tuple[tuple[str, str], ...] = (("sphere", "hemisphere"), ("pipe", "half_pipe"))


@dataclass(frozen=True)
class EvalReport:
    class_names: tuple[str, ...]
    confusion: npt.NDArray[np.int64]  # [true, predicted]

    @classmethod
    def from_predictions(cls, class_names: Sequence[str], true: npt.ArrayLike, pred: npt.ArrayLike) -> EvalReport:
        k = len(class_names)
        t, p = np.asarray(true, dtype=np.int64), np.asarray(pred, dtype=np.int64)
        cm = np.zeros((k, k), dtype=np.int64)
        np.add.at(cm, (t, p), 1)
        return cls(tuple(class_names), cm)

    @property
    def n(self) -> int:
        return int(self.confusion.sum())

    @property
    def accuracy(self) -> float:
        return float(np.trace(self.confusion) / max(self.n, 1))

    def per_class(self) -> dict[str, dict[str, float]]:
        cm = self.confusion
        tp = np.diag(cm).astype(float)
        pred_n, true_n = cm.sum(axis=0), cm.sum(axis=1)
        prec = np.divide(tp, pred_n, out=np.zeros_like(tp), where=pred_n > 0)
        rec = np.divide(tp, true_n, out=np.zeros_like(tp), where=true_n > 0)
        f1 = np.divide(2 * prec * rec, prec + rec, out=np.zeros_like(tp), where=(prec + rec) > 0)
        return {c: {"precision": float(prec[i]), "recall": float(rec[i]), "f1": float(f1[i]),
                    "support": int(true_n[i])} for i, c in enumerate(self.class_names)}

    def macro(self) -> dict[str, float]:
        rows = [r for r in self.per_class().values() if r["support"] > 0]
        if not rows:
            return {"precision": 0.0, "recall": 0.0, "f1": 0.0}
        return {m: float(np.mean([r[m] for r in rows])) for m in ("precision", "recall", "f1")}

    def pair_confusions(self) -> dict[str, dict[str, Any]]:
        """For each look-alike pair (a, b) present: how often a was called b and b called a."""
        out: dict[str, dict[str, Any]] = {}
        idx = {c: i for i, c in enumerate(self.class_names)}
        for a, b in LOOKALIKE_PAIRS:
            if a not in idx or b not in idx:
                continue
            ia, ib = idx[a], idx[b]
            na, nb = int(self.confusion[ia].sum()), int(self.confusion[ib].sum())
            ab, ba = int(self.confusion[ia, ib]), int(self.confusion[ib, ia])
            out[f"{a}/{b}"] = {f"{a}_as_{b}": ab, f"{b}_as_{a}": ba, f"n_{a}": na, f"n_{b}": nb,
                               "rate": (ab + ba) / max(na + nb, 1)}
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"n": self.n, "accuracy": self.accuracy, "macro": self.macro(), "per_class": self.per_class(),
                "confusion": self.confusion.tolist(), "class_names": list(self.class_names),
                "lookalike_pairs": self.pair_confusions()}

    def text(self) -> str:
        lines = [f"{'class':<12}{'precision':>10}{'recall':>8}{'f1':>8}{'n':>6}"]
        for c, r in self.per_class().items():
            lines.append(f"{c:<12}{r['precision']:>10.3f}{r['recall']:>8.3f}{r['f1']:>8.3f}{r['support']:>6d}")
        m = self.macro()
        lines.append(f"{'macro':<12}{m['precision']:>10.3f}{m['recall']:>8.3f}{m['f1']:>8.3f}{self.n:>6d}")
        lines.append(f"accuracy {self.accuracy:.3f}")
        for pair, d in self.pair_confusions().items():
            a, b = pair.split("/")
            lines.append(f"{pair}: {a} called {b} {d[f'{a}_as_{b}']}/{d[f'n_{a}']}, "
                         f"{b} called {a} {d[f'{b}_as_{a}']}/{d[f'n_{b}']}")
        return "\n".join(lines)


def plot_confusion(report: EvalReport, path: Path, title: str = "") -> Path:
    """Write the confusion matrix (row-normalized colours, counts written in) as a PNG."""
    import matplotlib  # lazy: matplotlib loads only when a figure is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cm = report.confusion
    norm = cm / np.maximum(cm.sum(axis=1, keepdims=True), 1)
    k = len(report.class_names)
    fig, ax = plt.subplots(figsize=(1.0 + 0.8 * k, 0.8 + 0.7 * k))
    ax.imshow(norm, cmap="Blues", vmin=0, vmax=1)
    for i in range(k):
        for j in range(k):
            if cm[i, j]:
                ax.text(j, i, str(cm[i, j]), ha="center", va="center",
                        color="white" if norm[i, j] > 0.5 else "black", fontsize=9)
    ax.set_xticks(range(k), report.class_names, rotation=45, ha="right")
    ax.set_yticks(range(k), report.class_names)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    ax.set_title(title or f"accuracy {report.accuracy:.3f} (n={report.n})")
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
    return path
