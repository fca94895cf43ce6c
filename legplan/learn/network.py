"""The learned initializer A_θ of Sec. IV of the TOWR-costs paper: filter (4), weighted fit (3), numpy inference.

* Filter, eq. (4): D_good = {(x_i, y_i) | task i converged and g(y_i) ≤ g_max}. A number is the
  paper's constant g_max. ``auto`` puts it at the start of the tail (`auto_g_max`): median + 3
  robust standard deviations (1.4826 × the median absolute deviation), recomputed on the values
  under it until it stays. The median and the MAD ignore up to half the tasks, and the repetition
  takes out what a heavy tail (30 % of the tasks, tested) still adds to them; on a normal body it
  keeps about 99.7 %. (≤ rather than the paper's <, so that a dataset of equal costs, e.g. without
  cost terms, keeps all its tasks.) Given the task vectors, ``auto`` looks for the tail of the cost
  *given the task* (`conditional_filter`): the tail rule on g(y_i) − ĝ(x_i), ĝ a quadratic
  least-squares fit of the cost over x, refitted on the kept tasks. Deliberate change from a
  constant g_max: the cost grows with the distance to the goal, so a constant threshold cuts the far
  tasks, not the poor local minima.
* Fit, eq. (3): θ = argmin Σ ‖A_θ x − y‖²_W with W = diag(w_c / σ_c²) for an output of category c
  (`CATEGORIES`: base linear, base angular, feet, forces, phase durations when they were optimized):
  w_c > 0 its weight, σ_c the category's RMS standard deviation in D_good, so each category's error
  is weighed in its own units at a comparable scale (a per-output σ_j would let outputs that hardly
  vary in the training tasks, e.g. near-fixed nodes, dominate the loss). scikit-learn's
  `MLPRegressor` (squared loss, tanh, Adam: its L-BFGS line search fails on outputs of this size) is
  fitted on standardized x and on √w_c/σ_c-scaled centred y, which is exactly that loss. A random `validation` fraction is held out.
  `FitParams` adds what a fit on few tasks needs against fitting their noise: the L2 penalty α on
  the weights, σ per category and node order (`scale` "order": a node category's values and its
  derivatives, whose units differ, N against N/s, each at its own spread) and an ensemble of K
  networks on the same split averaged (`parallel`: saved as one network of K parallel blocks, so
  init.h5 and `Network` stay as they are). The defaults are the fit as it was.
* Deliberate change from the paper's network, `FitParams.model` "polynomial": A_θ as a polynomial
  of the standardized task vector (all monomials up to `degree`), fitted to the same weighted loss
  by ridge-regularized least squares. On a few hundred tasks of a smooth task-to-solution map it
  generalizes where the network, fitted by Adam, does not; it is a `Network` without hidden layers
  whose input layer forms the monomials (`monomials`, `Network.degree`; init.h5's `degree`
  attribute, absent in files written before it: 1).
* init.h5 (kind "init"): the layers' weights and biases and the input/output normalization as plain
  HDF5 arrays (no pickle), the layout and the task space; `Network` evaluates it in numpy, so
  planning with it needs no training library. `LearnedInit` is an initializer (`legplan.dyn.init`).
"""

from __future__ import annotations

import json
import logging
import math
import os
import warnings
from dataclasses import dataclass
from itertools import combinations_with_replacement
from pathlib import Path

import numpy as np

from legplan.errors import LegplanError, SpecError
from legplan.parameters import Parameters, param
from legplan.learn.layout import CATEGORIES, category_index, check_layout, layout_of, read_layout, split
from legplan.learn.space import X_NAMES, task_vector

log = logging.getLogger(__name__)

KIND = "init"
SPACE_SLACK = 1e-9  # m or rad: a task on a range's bound, written in decimal, is inside it
MAD_SIGMA = 1.4826  # MAD of a normal distribution × this = its standard deviation
TAIL_SIGMAS = 3.0
DEFAULT_WEIGHTS = {"base_lin": 2.0, "base_ang": 1.0, "feet": 1.0, "forces": 2.0, "phases": 2.0}
"""W per category: the paper found base positions, phase durations and forces the most crucial to
initialize well, and its best weights "coarsely tuned" with all categories included; these follow
that, untuned here."""
ACTIVATIONS = {"tanh": np.tanh, "relu": lambda a: np.maximum(a, 0.0), "identity": lambda a: a}


def auto_g_max(cost: np.ndarray, passes: int = 20) -> float:
    """Start of the tail of a cost distribution: median + 3 × 1.4826 × MAD of the costs under the
    previous threshold, repeated until the threshold stays (module docstring)."""
    cost = np.asarray(cost, float)
    kept, threshold = cost, np.inf
    for _ in range(passes):
        median = float(np.median(kept))
        new = median + TAIL_SIGMAS * MAD_SIGMA * float(np.median(np.abs(kept - median)))
        if new == threshold:
            break
        threshold, kept = new, cost[cost <= new]
    return threshold


FIT_TASKS_PER_FEATURE = 5  # `filter_good` fits ĝ only with at least this many tasks per coefficient


def filter_good(success: np.ndarray, cost: np.ndarray, g_max: float | str, source: str = "dataset",
                x: np.ndarray | None = None) -> tuple[np.ndarray, CostBound]:
    """Mask of D_good (eq. (4), converged tasks only) and the filter as a `CostBound`: a number is
    g_max itself; `auto` is the start of the tail of the costs, or with the task vectors `x` (enough
    tasks for the fit) of the costs' excess over the quadratic fit ĝ(x) (`conditional_filter`)."""
    cost = np.asarray(cost, float)
    ok = np.asarray(success, bool) & np.isfinite(cost)
    if not ok.any():
        raise LegplanError(f"{source}: field 'success': no converged task to train on")
    features = quadratic_features(x) if g_max == "auto" and x is not None else None
    if features is not None and ok.sum() >= FIT_TASKS_PER_FEATURE * features.shape[1]:
        good, threshold, coef = conditional_filter(features, cost, ok)
    else:
        threshold = auto_g_max(cost[ok]) if g_max == "auto" else float(g_max)
        good, coef = ok & (cost <= threshold), np.empty(0)
    if not good.any():
        raise LegplanError(f"{source}: field 'cost': no converged task has g(y) <= g_max = {threshold:g}")
    columns = np.empty((cost.size, 0)) if x is None else np.asarray(x, float)  # `quadratic_features`' standardization
    return good, CostBound(columns.mean(axis=0), columns.std(axis=0), coef, float(threshold))


def filter_rule(g_max: float, conditional: bool) -> str:
    """The filter of a train report in words: ``g <= 3.5`` or ``g <= g_fit(x) + 0.66``."""
    return f"g <= g_fit(x) + {g_max:.4g}" if conditional else f"g <= {g_max:.4g}"


def quadratic_features(x: np.ndarray, standardization: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """1, x_j and x_j x_k (j ≤ k) of the standardized non-constant columns of x, by x's own column
    means and spreads or by `standardization` (mean, std) of other tasks (std 0: a constant column)."""
    x = np.atleast_2d(np.asarray(x, float))
    mean, std = (x.mean(axis=0), x.std(axis=0)) if standardization is None else standardization
    z = (x[:, std > 0] - mean[std > 0]) / std[std > 0]
    pairs = [z[:, j] * z[:, k] for j in range(z.shape[1]) for k in range(j, z.shape[1])]
    return np.column_stack([np.ones(len(x)), z, *pairs])


@dataclass(frozen=True)
class CostBound:
    """The filter of eq. (4) as a bound on the cost of one task's solution: g ≤ ĝ(x) + `threshold`,
    ĝ the quadratic fit of `conditional_filter` (coefficients `coef` over `quadratic_features` by the
    training tasks' `mean` and `std`), or g ≤ g_max = `threshold` for a constant one (`coef` empty).
    A plan whose cost is above it would not have been kept to train on: the "polish" warm stage
    optimizes its costs (`legplan.dyn.planner`, the "polish" stages)."""

    mean: np.ndarray
    std: np.ndarray
    coef: np.ndarray
    threshold: float

    @property
    def conditional(self) -> bool:
        """Whether it bounds g − ĝ(x) (the conditional filter) rather than g."""
        return self.coef.size > 0

    def __call__(self, x: np.ndarray, tolerance: float = 1.0) -> float:
        """ĝ(x) + tolerance·threshold for one task vector x (tolerance 1: the filter's own bound)."""
        fit = float(quadratic_features(x, (self.mean, self.std))[0] @ self.coef) if self.coef.size else 0.0
        return fit + tolerance * self.threshold


def conditional_filter(features: np.ndarray, cost: np.ndarray, ok: np.ndarray, passes: int = 10
                       ) -> tuple[np.ndarray, float, np.ndarray]:
    """D_good by the tail of the cost given the task (module docstring): ĝ fitted by least squares on
    the tasks' `quadratic_features` (rows) of the kept tasks, the tail rule (`auto_g_max`) on the
    residuals of the converged ones, repeated until the kept set stays. Returns the mask, the
    residual threshold and ĝ's coefficients."""
    kept, threshold = ok.copy(), np.inf
    for _ in range(passes):
        coef = np.linalg.lstsq(features[kept], cost[kept], rcond=None)[0]
        residual = cost - features @ coef
        threshold = auto_g_max(residual[ok])
        now = ok & (residual <= threshold)
        if np.array_equal(now, kept):
            break
        kept = now
    return now, threshold, coef


def read_weights(path: str | os.PathLike | None) -> dict[str, float]:
    """W per category from a YAML file (`base_lin: 2.0` ...; missing categories keep the default)."""
    if path is None:
        return dict(DEFAULT_WEIGHTS)
    from legplan.specio import FieldReader, read_yaml_mapping

    data = read_yaml_mapping(path, "weights file")
    reader = FieldReader(path)
    reader.unknown(data, CATEGORIES)
    return {name: reader.positive(data[name], name) if name in data else DEFAULT_WEIGHTS[name]
            for name in CATEGORIES}


def weight_count(inputs: int, hidden: tuple[int, ...], outputs: int) -> int:
    """Weights and biases of a fully connected network with these layer sizes."""
    sizes = [int(inputs), *map(int, hidden), int(outputs)]
    return sum((a + 1) * b for a, b in zip(sizes[:-1], sizes[1:]))


def monomials(z: np.ndarray, degree: int) -> np.ndarray:
    """The products of the columns of z (n, m) of degree 1 … `degree`, each set of columns once
    (`itertools.combinations_with_replacement` order): z itself for degree 1."""
    if degree == 1:
        return z
    return np.column_stack([np.prod(z[:, list(c)], axis=1) for d in range(1, degree + 1)
                            for c in combinations_with_replacement(range(z.shape[1]), d)])


@dataclass
class Network:
    """A fully connected network with its normalization: y = out_scale·f(x_n) + out_offset,
    x_n = (x − in_offset) / in_scale, f the `monomials` of x_n up to `degree` (1: x_n itself),
    then hidden layers of `activation` and a linear output layer (no hidden layer: a polynomial)."""

    weights: list[np.ndarray]
    biases: list[np.ndarray]
    activation: str
    in_offset: np.ndarray
    in_scale: np.ndarray
    out_offset: np.ndarray
    out_scale: np.ndarray
    degree: int = 1

    def predict(self, x: np.ndarray) -> np.ndarray:
        """y for x (n, |x|) or (|x|,), in numpy."""
        x = np.asarray(x, float)
        h = monomials((np.atleast_2d(x) - self.in_offset) / self.in_scale, self.degree)
        act = ACTIVATIONS[self.activation]
        for k, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = h @ w + b
            if k < len(self.weights) - 1:
                h = act(h)
        y = h * self.out_scale + self.out_offset
        return y[0] if x.ndim == 1 else y


@dataclass(frozen=True)
class FitParams(Parameters):
    """How eq. (3) is fitted (module docstring); the defaults are the fit without them."""

    what = "fit"

    alpha: float = param(1e-4, "[0, 100]", "α", "L2 penalty on the network's weights (scikit-learn's alpha)")
    scale: str = param("category", ("category", "order"), "σ_c",
                       "output normalization: one σ per category, or per category and node order (values, derivatives)")
    ensemble: int = param(1, "[1, 8]", "K", "networks fitted on the same split (seeds K·seed … K·seed + K − 1), averaged")
    model: str = param("network", ("network", "polynomial"), "A_θ",
                       "the paper's network, or a polynomial of the task vector (module docstring)")
    degree: int = param(3, "[1, 4]", doc="largest degree of the polynomial's monomials")
    ridge: float = param(1e-6, "(0, 1]", "λ",
                         "the polynomial's ridge penalty per task on its coefficients (standardized units)")


def parallel(nets: list[Network]) -> Network:
    """The mean of networks of the same shape, activation and normalization as one network: hidden
    layers side by side (the first layer's weights stacked by column, later ones block-diagonal) and
    the output layer summing the blocks' outputs over their count."""
    if len(nets) == 1:
        return nets[0]
    first, count = nets[0], len(nets)
    weights = [np.hstack([n.weights[0] for n in nets])]
    for k in range(1, len(first.weights) - 1):
        block = np.zeros((sum(n.weights[k].shape[0] for n in nets), sum(n.weights[k].shape[1] for n in nets)))
        rows = cols = 0
        for n in nets:
            w = n.weights[k]
            block[rows:rows + w.shape[0], cols:cols + w.shape[1]] = w
            rows, cols = rows + w.shape[0], cols + w.shape[1]
        weights.append(block)
    weights.append(np.vstack([n.weights[-1] for n in nets]) / count)
    biases = [np.concatenate([n.biases[k] for n in nets]) for k in range(len(first.biases) - 1)]
    biases.append(sum(n.biases[-1] for n in nets) / count)
    return Network(weights, biases, first.activation, first.in_offset, first.in_scale, first.out_offset, first.out_scale)


def output_groups(layout: dict[str, int], scale: str) -> tuple[np.ndarray, np.ndarray]:
    """Per entry of y the group whose spread σ normalizes it (`FitParams.scale`) and the index of its
    category: a category, or a category's value or derivative nodes (the node categories are
    (nodes, value|derivative, xyz) flat; the phase durations one group)."""
    cats = category_index(layout)
    if scale == "category":
        return cats, cats
    order = np.concatenate([np.tile(np.repeat([0, 1], 3), layout[c] // 6) if c != "phases" else np.zeros(layout[c], int)
                            for c in CATEGORIES])
    return 2 * cats + order, cats


def _scale(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation per column (1 for a constant column)."""
    std = a.std(axis=0)
    return a.mean(axis=0), np.where(std > 1e-9 * np.maximum(1.0, np.abs(a).max(axis=0)), std, 1.0)


def fit(x: np.ndarray, y: np.ndarray, layout: dict[str, int], weights: dict[str, float], hidden: tuple[int, ...],
        seed: int, validation: float = 0.2, max_iter: int = 1000, params: FitParams = FitParams()):
    """Fit eq. (3) on (x, y) (module docstring); returns the `Network`, a report of the fit
    (weighted mean squared error on the training and validation tasks, RMS error per category) and
    the last fitted scikit-learn model."""
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor
    from threadpoolctl import threadpool_limits

    from legplan.budget import check_size

    if params.model == "polynomial":
        features = math.comb(x.shape[1] + params.degree, params.degree) - 1  # `monomials`' columns
        check_size("weights", weight_count(features, (), y.shape[1]), "--param degree")
    else:
        check_size("weights", weight_count(x.shape[1], tuple(params.ensemble * h for h in hidden), y.shape[1]), "--hidden")
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(x))
    n_val = int(round(validation * len(x))) if len(x) >= 5 else 0
    val, train = order[:n_val], order[n_val:]
    in_offset, in_scale = _scale(x[train])
    y_mean = y[train].mean(axis=0)
    groups, group_cats = output_groups(layout, params.scale)
    size = 2 * len(CATEGORIES)  # enough for either grouping; an empty group: no outputs
    counts = np.maximum(np.bincount(groups, None, size), 1)
    sigma = np.sqrt(np.bincount(groups, y[train].var(axis=0), size) / counts)
    sigma = np.where(sigma > 0, sigma, 1.0)
    w_c = np.array([weights[c] for c in CATEGORIES])[group_cats]
    out_scale = sigma[groups] / np.sqrt(w_c)
    members = []
    if params.model == "polynomial":
        with threadpool_limits(limits=1):
            members.append(_polynomial(x[train], (y[train] - y_mean) / out_scale, in_offset, in_scale, y_mean, out_scale,
                                       params))
        model = None
    for j in range(params.ensemble if params.model == "network" else 0):
        model = MLPRegressor(hidden_layer_sizes=hidden, activation="tanh", solver="adam", max_iter=max_iter,
                             alpha=params.alpha, random_state=int(seed) * params.ensemble + j, tol=1e-6,
                             n_iter_no_change=20, batch_size=min(32, len(train)))
        # one BLAS thread: a multi-threaded product sums in another order, and the fit's epochs carry that
        # rounding into the weights, so the same datasets and seed would not always give the same network
        with warnings.catch_warnings(record=True) as caught, threadpool_limits(limits=1):
            warnings.simplefilter("always", ConvergenceWarning)
            model.fit((x[train] - in_offset) / in_scale, (y[train] - y_mean) / out_scale)
        for warning in caught:  # reaching max_iter epochs is no error: the validation loss tells the fit
            log.info("fit: %s", str(warning.message).splitlines()[0])
        members.append(Network([np.asarray(w, float) for w in model.coefs_],
                               [np.asarray(b, float) for b in model.intercepts_], "tanh", in_offset, in_scale, y_mean,
                               out_scale))
    net = parallel(members)

    def weighted_mse(rows):
        return float(np.mean(((net.predict(x[rows]) - y[rows]) / out_scale) ** 2)) if len(rows) else np.nan

    pick = val if len(val) else train
    err = net.predict(x[pick]) - y[pick]
    cats = category_index(layout)
    report = {"train_tasks": len(train), "validation_tasks": len(val), "train_loss": weighted_mse(train),
              "validation_loss": weighted_mse(val), "fit_iterations": int(model.n_iter_) if model is not None else 1,
              **{f"rms_{c}": float(np.sqrt(np.mean(err[:, cats == k] ** 2))) for k, c in enumerate(CATEGORIES)
                 if layout[c] > 0}}
    return net, report, model


def _polynomial(x, target, in_offset, in_scale, out_offset, out_scale, params: FitParams) -> Network:
    """The polynomial A_θ (module docstring): ridge least squares (scikit-learn's `Ridge`, penalty
    `params.ridge` per task) of the scaled `target` on the `monomials` of the standardized x, the
    intercept unpenalized, in the bias; the features are the ones `Network.predict` forms."""
    from sklearn.linear_model import Ridge

    features = monomials((x - in_offset) / in_scale, params.degree)
    model = Ridge(alpha=params.ridge * len(x), fit_intercept=True, solver="cholesky").fit(features, target)
    coef = np.asarray(model.coef_, float).reshape(target.shape[1], -1).T.copy()
    bias = np.asarray(model.intercept_, float).reshape(-1)
    return Network([coef], [bias], "identity", in_offset, in_scale, out_offset, out_scale, params.degree)


def save_init(path, net: Network, layout: dict[str, int], space: dict, report: dict, settings: dict, seed: int,
              inputs, overwrite: bool, bound: CostBound | None = None) -> None:
    """init.h5: plain arrays only (module docstring), and the training filter's `CostBound` (`filter/`)."""
    from legplan.artefacts import write_artefact, write_dataset, write_summary

    with write_artefact(path, KIND, params=settings, seed=seed, inputs=inputs, overwrite=overwrite) as f:
        f.attrs["space"] = json.dumps(space)
        f.attrs["activation"] = net.activation
        f.attrs["layers"] = len(net.weights)
        if net.degree != 1:  # files of the paper's network keep their attributes as they were
            f.attrs["degree"] = net.degree
        for k, (w, b) in enumerate(zip(net.weights, net.biases)):
            write_dataset(f, f"network/layer_{k}/weights", w)
            write_dataset(f, f"network/layer_{k}/biases", b)
        for name in ("in_offset", "in_scale", "out_offset", "out_scale"):
            write_dataset(f, f"normalization/{name}", getattr(net, name))
        for name in CATEGORIES:
            write_dataset(f, f"layout/{name}", np.int64(layout[name]))
        if bound is not None:
            for name in ("mean", "std", "coef"):
                write_dataset(f, f"filter/{name}", getattr(bound, name))
            write_dataset(f, "filter/threshold", np.float64(bound.threshold))
        write_summary(f, report)


def load_init(path) -> tuple[Network, dict[str, int], dict]:
    """The network, layout and space record of an init.h5 (its filter: `load_bound`)."""
    from legplan.artefacts import open_artefact, read_array

    with open_artefact(path, kind=KIND) as f:
        activation = str(f.attrs["activation"])
        if activation not in ACTIVATIONS:
            raise LegplanError(f"{path}: field 'activation' is unknown: {activation!r}")
        layers = int(f.attrs["layers"])
        degree = int(f.attrs.get("degree", 1))
        if not 1 <= degree <= 4:
            raise LegplanError(f"{path}: field 'degree' must be in [1, 4], got {degree}")
        net = Network([read_array(f, f"network/layer_{k}/weights", ndim=2) for k in range(layers)],
                      [read_array(f, f"network/layer_{k}/biases", ndim=1) for k in range(layers)], activation,
                      *(read_array(f, f"normalization/{n}", ndim=1) for n in ("in_offset", "in_scale", "out_offset", "out_scale")),
                      degree)
        layout = read_layout(f)
        space = json.loads(f.attrs["space"])
    return net, layout, space


def missing_filter(path) -> LegplanError:
    """The one-line error for an init.h5 without the `CostBound` that the "polish" warm stage reads."""
    return LegplanError(f"{path}: field 'filter' is missing (trained before init.h5 kept its filter: train it "
                        "again with legplan learn train); --warm-stage polish needs it")


def load_bound(path) -> CostBound | None:
    """The training filter's `CostBound` of an init.h5; None for a file trained without it."""
    from legplan.artefacts import open_artefact, read_array

    with open_artefact(path, kind=KIND) as f:
        if "filter" not in f:
            return None
        bound = CostBound(read_array(f, "filter/mean", ndim=1), read_array(f, "filter/std", ndim=1),
                          read_array(f, "filter/coef", ndim=1), float(read_array(f, "filter/threshold", ndim=0)))
    varying = int(np.sum(bound.std > 0))
    expected = 1 + varying + varying * (varying + 1) // 2
    if bound.mean.size != len(X_NAMES) or bound.std.size != len(X_NAMES):
        raise LegplanError(f"{path}: field 'filter/mean' and 'filter/std' need {len(X_NAMES)} entries (the task "
                           f"vector), got {bound.mean.size} and {bound.std.size}")
    if bound.coef.size not in (0, expected):
        raise LegplanError(f"{path}: field 'filter/coef' has {bound.coef.size} entries, expected {expected} "
                           f"(the quadratic fit over {varying} varying task inputs) or none")
    return bound


def check_space(init_path, trained: dict, space: dict) -> None:
    """One-line error when init.h5 was trained for another map, gait, strides or duration than `space`.
    The map is the same map when its file's content is (`map_sha256`; records without it: the same
    file name), wherever and however the path to it was written."""
    for key in ("map", "gait", "strides", "duration"):
        if key == "map":
            same = (trained["map_sha256"] == space["map_sha256"] if "map_sha256" in trained and "map_sha256" in space
                    else Path(trained["map"]).name == Path(space["map"]).name)
        else:
            same = trained[key] == space[key]
        if not same:
            raise SpecError(f"{init_path}: field 'space.{key}' is {trained[key]!r}, the task space "
                            f"has {space[key]!r} (trained for another task space)")


class LearnedInit:
    """A_θ as an initializer: ``(form, model, terrain, start, goal, start_feet) -> guess`` from init.h5
    (picklable by path: it loads the file again where it is unpickled). Its guesses are solutions of
    nearby tasks (`near_solution`): `legplan.dyn.planner.plan` solves from them directly (its
    near-solution stages), not through the heuristic's feasibility stage."""

    near_solution = True

    def __init__(self, path: str | os.PathLike):
        self.path = os.fspath(path)
        self.net, self.layout, self.space = load_init(self.path)
        self.bound = load_bound(self.path)

    def __getstate__(self):
        return {"path": self.path}

    def __setstate__(self, state):
        self.__init__(state["path"])

    def __eq__(self, other):  # the same file: a task's copy in a worker is the task the command built
        return isinstance(other, LearnedInit) and other.path == self.path

    def __hash__(self):
        return hash(self.path)

    def check_task(self, task, params=None) -> None:
        """Before planning: one-line error when a `DynTask`'s variable layout (gait, strides, duration,
        base knots of `params`, a `DynParams`, default its defaults) is not the one this network was
        trained for."""
        from legplan.dyn.problem import DynParams, task_formulation
        from legplan.robots import load_robot

        height = load_robot(self.space.get("robot", "anymal")).centroidal.base_height   # the space's robot (its default)
        form = task_formulation(task, params or DynParams(), timed=self.sets_timing, base_height=height)
        check_layout(self.layout, layout_of(form, phases=True), self.path)

    @property
    def sets_timing(self) -> bool:
        """Whether its guesses carry phase durations (trained with them), which set the plan's timing."""
        return self.layout.get("phases", 0) > 0

    def check_in_space(self, task) -> None:
        """Before planning: one-line error when a `DynTask`'s start or goal (x, y, yaw) lies outside the
        ranges of the task space this network was trained on. Outside them the network extrapolates
        and its guess is no nearby solution, which the one-stage near-solution solve relies on: such a
        task is refused (plan it with `--init heuristic`) rather than planned from a poor guess."""
        name = os.path.basename(self.path)
        for end in ("start", "goal"):
            ranges = self.space.get(end)
            if not ranges:
                continue
            for axis, value, (lo, hi) in zip(("x", "y", "yaw"), getattr(task, end), ranges):
                if not lo - SPACE_SLACK <= value <= hi + SPACE_SLACK:
                    raise LegplanError(
                        f"--init {name}: the task's {end} {axis} = {value:g} lies outside the range it was trained "
                        f"on, [{lo:g}, {hi:g}] (task space '{self.space.get('name')}'): plan it with --init heuristic")

    def cost_bound(self, task, tolerance: float = 1.0) -> float:
        """The largest cost of a `DynTask`'s plan that the training filter would keep (`CostBound`),
        its threshold times `tolerance`; a one-line error for an init.h5 trained without it."""
        if self.bound is None:
            raise missing_filter(self.path)
        return self.bound(task_vector(task.start, task.goal), tolerance)

    def __call__(self, form, model, terrain, start, goal, start_feet) -> dict[str, np.ndarray]:
        check_layout(self.layout, layout_of(form, phases=True), self.path)
        x = task_vector((*start.position[:2], start.euler[2]), (*goal.position[:2], goal.euler[2]))
        return split(self.net.predict(x), self.layout)
