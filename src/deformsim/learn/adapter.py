"""A trained model adapted to the user's own photos, unlabelled or labelled (``deformsim adapt``).

- ``probe`` (self-training in feature space, after Lee 2013 and Xie et al. 2020's student that replaces its
  teacher): an L2-regularised logistic regression on the photos' pooled features (each backbone's trainable
  layers, the mean over an ensemble's members, standardised over the photos) is fitted to the synthetic model's
  judgements of the same photos (hard pseudo-labels, each photo weighted by the model's confidence ``|2p - 1|``,
  both classes weighing alike), and then judges them in its place. A linear probe cannot follow every error of the
  network that made its targets: photos that look alike end up judged alike, which corrects the synthetic model
  where its errors are scattered over the features (the cluster assumption) and changes nothing where they are not.
- ``prior``: the share of deformed parts among the photos, estimated by EM from the synthetic model's probabilities
  (Saerens, Latinne, Decaestecker 2002), shifts its logit: the renders are balanced, a user's photos rarely are.
- ``probe+prior``: the probe on the shifted judgements, the shift kept.

Labelled photos given beside (``labels`` of :func:`fit_adapter`) join the probe's fit with their labels, each
weighing ``labelled_weight`` confident unlabelled ones. Labels of an unlabelled folder are never read: its photos
are listed recursively and ordered by content (sha256), so renaming, moving between folders or flattening them
gives the same adapter to the last bit (:mod:`deformsim.learn.adapt_stage`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from deformsim.errors import UserError

MIN_PHOTOS = 8  # the fewest unlabelled photos whose feature statistics and prior an adapter estimates
FEW_PHOTOS = 40  # below this, a probe judged other photos 2-21 points worse on both parts (bench adapt --n)
UNLABELLED = ("probe", "prior", "probe+prior")  # what adapts on unlabelled photos alone
ADAPTERS = (*UNLABELLED, "stack")  # stack: a residual on labelled photos (deformsim.learn.stack)
NETWORKS = ("fixmatch", "adamatch", "mcc", "cdan")  # the networks themselves trained on (deformsim.learn.fixmatch)
METHODS = (*ADAPTERS, *NETWORKS)


@dataclass(frozen=True)
class AdaptRecipe:
    """How a model adapts to photos: ``probe`` (the feature probe), ``prior`` (the EM prior shift) or both, ``stack``
    (with labelled photos), or the networks trained on with them (``fixmatch``, ``adamatch``, ``mcc``)."""

    method: str = "probe"
    l2: float = 1.0  # the probe's L2 penalty on standardised features (against the photos' mean loss)
    rounds: int = 1  # self-training rounds: targets from the synthetic model, then from the probe
    labelled_weight: float = 4.0  # a labelled photo counts as this many fully confident unlabelled ones
    steps: int = 200  # fixmatch, adamatch, mcc: training steps of each network

    @property
    def probe(self) -> bool:
        """Whether the method reads the photos' features (all but ``prior``)."""
        return self.method != "prior"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise UserError(f"adapt method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if not 1e-6 <= self.l2 <= 1e6:
            raise UserError(f"adapt l2 must lie in [1e-6, 1e6], got {self.l2}")
        if not 1 <= self.rounds <= 20:
            raise UserError(f"adapt rounds must lie in [1, 20], got {self.rounds}")
        if not 1 <= self.steps <= 100_000:
            raise UserError(f"adapt steps must lie in [1, 100000], got {self.steps}")
        if not 0 < self.labelled_weight <= 1e4:
            raise UserError(f"adapt labelled_weight must lie in (0, 1e4], got {self.labelled_weight}")


def logit(p: np.ndarray) -> np.ndarray:
    p = np.clip(np.asarray(p, dtype=np.float64), 1e-6, 1 - 1e-6)
    return np.log(p) - np.log1p(-p)


def sigmoid(z: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-np.clip(np.asarray(z, dtype=np.float64), -700, 700)))  # exp overflows past 709


def em_prior(p: np.ndarray, train_prior: float = 0.5, iters: int = 200, tol: float = 1e-9) -> float:
    """The share of deformed parts among photos whose posteriors under a model trained at ``train_prior`` are
    ``p`` (Saerens et al. 2002): EM on the prior, the posteriors re-weighted by each new estimate."""
    p = np.clip(np.asarray(p, dtype=np.float64), 1e-6, 1 - 1e-6)
    pi = train_prior
    for _ in range(iters):
        a = p * pi / train_prior
        q = a / (a + (1 - p) * (1 - pi) / (1 - train_prior))
        new = float(np.clip(q.mean(), 1e-3, 1 - 1e-3))
        if abs(new - pi) < tol:
            return new
        pi = new
    return pi


def fit_logistic(x: np.ndarray, target: np.ndarray, weight: np.ndarray, l2: float,
                 offset: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Coefficients and bias minimising the weighted mean cross-entropy of ``sigmoid(offset + x @ w + b)`` against
    the soft ``target`` plus ``l2 / 2 * |w|^2`` (float64 L-BFGS from zero: deterministic on a CPU)."""
    import torch

    with torch.random.fork_rng(devices=[]):
        xs, ts, ws = (torch.as_tensor(np.asarray(a, dtype=np.float64)) for a in (x, target, weight))
        off = torch.zeros(len(xs), dtype=torch.float64) if offset is None else torch.as_tensor(offset, dtype=torch.float64)
        w = torch.zeros(xs.shape[1], dtype=torch.float64, requires_grad=True)
        b = torch.zeros(1, dtype=torch.float64, requires_grad=True)
        opt = torch.optim.LBFGS([w, b], max_iter=300, tolerance_grad=1e-9, tolerance_change=1e-12,
                                history_size=20, line_search_fn="strong_wolfe")
        total = ws.sum()

        def closure():
            opt.zero_grad()
            z = off + xs @ w + b
            loss = (ws * torch.nn.functional.binary_cross_entropy_with_logits(z, ts, reduction="none")).sum() / total
            loss = loss + 0.5 * l2 * (w * w).sum()
            loss.backward()
            return loss

        opt.step(closure)
    return w.detach().numpy().copy(), float(b.detach()[0])


def _balanced(target: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """``weight`` rescaled so both classes (soft ``target``) weigh the same in all."""
    pos, neg = float((weight * target).sum()), float((weight * (1 - target)).sum())
    return weight * (target * (0.5 / max(pos, 1e-9)) + (1 - target) * (0.5 / max(neg, 1e-9))) * weight.sum()


@dataclass
class Adapter:
    """What adapting fitted: ``anchor`` times the synthetic logit plus the prior ``shift`` plus the probe on
    standardised features (``coef`` empty for ``prior``); :meth:`apply` gives the adapted P(deformed)."""

    method: str
    prior: float  # the estimated share of deformed parts among the photos
    shift: float
    anchor: float  # the weight of the synthetic model's own logit: 1 for prior, 0 for the probe that replaces it
    mean: list[float]
    scale: list[float]
    coef: list[float]
    bias: float
    photos: int
    labelled: int

    def apply(self, p: np.ndarray, features: np.ndarray | None) -> np.ndarray:
        z = self.anchor * logit(p) + self.shift
        if self.coef:
            z = z + self.probe_logit(features)
        return sigmoid(z)

    def probe_logit(self, features: np.ndarray) -> np.ndarray:
        x = (np.asarray(features, dtype=np.float64) - np.asarray(self.mean)) / np.asarray(self.scale)
        return x @ np.asarray(self.coef) + self.bias

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data, where: str = "the model") -> "Adapter":
        """The adapter saved in a model; one line naming ``where`` when it is not one."""
        try:
            adapter = cls(**data)
            d = len(adapter.coef)
            ok = (adapter.method in ADAPTERS and len(adapter.mean) == len(adapter.scale) and d in (0, len(adapter.mean))
                  and all(np.isfinite(np.asarray(v, dtype=np.float64)).all() for v in (adapter.mean, adapter.scale,
                                                                                        adapter.coef))
                  and min(adapter.scale, default=1.0) > 0 and np.isfinite([adapter.shift, adapter.bias, adapter.anchor]).all())
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise UserError(f"{where} is not a deformsim model: its adapter is not a valid one")
        return adapter


def fit_adapter(p: np.ndarray, features: np.ndarray, recipe: AdaptRecipe = AdaptRecipe(),
                labels: np.ndarray | None = None) -> Adapter:
    """The adapter of photos whose synthetic-model probabilities are ``p`` and whose frozen features are
    ``features`` (N, D); ``labels`` (N, 1 deformed, 0 intact, -1 unknown) where the user gave some."""
    p = np.asarray(p, dtype=np.float64)
    n = len(p)
    labels = np.full(n, -1) if labels is None else np.asarray(labels)
    known = labels >= 0
    prior = em_prior(p[~known]) if (~known).sum() >= MIN_PHOTOS else 0.5
    if known.any():  # the user's labels say more about the share than the model's guesses
        prior = float((labels[known].sum() + prior * (~known).sum()) / n)
    shift = float(np.log(prior) - np.log1p(-prior)) if "prior" in recipe.method else 0.0
    if recipe.method == "prior":
        return Adapter("prior", prior, shift, 1.0, [], [], [], 0.0, n, int(known.sum()))
    x = np.asarray(features, dtype=np.float64)
    mean, scale = x.mean(0), x.std(0) + 1e-6
    x = (x - mean) / scale
    q = sigmoid(logit(p) + shift)
    coef, bias = np.zeros(x.shape[1]), 0.0
    for _ in range(recipe.rounds):
        target = np.where(known, labels, q >= 0.5).astype(np.float64)
        weight = _balanced(target, np.where(known, recipe.labelled_weight, np.abs(2 * q - 1)))
        coef, bias = fit_logistic(x, target, weight, recipe.l2)
        q = sigmoid(shift + x @ coef + bias)
    return Adapter(recipe.method, prior, shift, 0.0, mean.tolist(), scale.tolist(), coef.tolist(), bias, n,
                   int(known.sum()))
