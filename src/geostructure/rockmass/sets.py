"""Joint sets: the families of like-oriented planes, and their statistics.

A plane's pole is an axis (p and -p are the same plane), so the poles are clustered as axial
data: a mixture of ``K`` bipolar Fisher distributions, f(x) = kappa / (4 pi sinh kappa)
cosh(kappa mu.x), and a uniform component for planes that belong to no set, fitted by EM
with each plane weighted by its area (a large joint is more of the rock mass than a small
chip). Each set's mean axis is the principal eigenvector of its weighted orientation tensor
sum(w x x^T), not a resultant vector: for steep planes whose poles straddle the horizon,
half the poles point the "wrong" way and a resultant mixes them (mplstereonet's
``find_fisher_stats``, its issue #39). The number of sets, when not given, is the one of
smallest BIC (Schwarz 1978) among 1 to ``max_sets`` whose set means all lie at least
``MIN_SEPARATION`` apart: the facets of one joint plane share its orientation exactly, so the
poles of a set are a cluster of tight spikes that a likelihood alone would split into sets
a geologist would call one.

Statistics per set follow Fisher (1953) on the poles turned to the mean's side, each plane
counted once, as Dips reports them: R, Fisher's K = (N - 1) / (N - R), the 95% cone
alpha95 = arccos(1 - (N - R) / R (20^(1 / (N - 1)) - 1)), and the spherical variance
1 - R / N.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from geostructure.core.orientation import Frame, orientation_from_normals
from geostructure.errors import GeoStructureWarning, ParameterError
from geostructure.rockmass.joints import joint_counter

#: Sets tried at most when the number is chosen by BIC.
MAX_SETS = 6
#: EM starts per number of sets (the first from the heaviest pole, the others drawn).
EM_STARTS = 8
#: Fewest planes a set may hold.
MIN_SET_PLANES = 3
#: Fewest joints (planes not coplanar with each other) a set must hold for its number of
#: sets to be chosen.
MIN_SET_JOINTS = 3
#: Smallest angle (degrees) between two sets' mean poles when the number of sets is chosen.
MIN_SEPARATION = 20.0
#: Concentration never exceeded in the EM. The facets of one joint plane share its pole, so a
#: set's poles are tight spikes; unbounded, a component shrinks onto the largest spike and
#: leaves the set's other planes to the uniform component. Sets tighter than this are rare
#: (Dips' typical K run 20 to 200), and the K reported is computed from the members anyway.
MAX_KAPPA = 100.0
#: An EM start stops when even at its present rate it would end this far (log-likelihood)
#: below the best start's (:func:`_fit_mixture`).
HOPELESS_MARGIN = 1.0


@dataclass
class JointSets:
    """The sets found among a run's planes (:func:`find_sets`).

    Parameters
    ----------
    labels : (P,) int array
        Each plane's set: 0, 1, ... by decreasing total area, or -1 for none.
    mean_normal : (S, 3) array
        Each set's mean normal, upward, unit, in the cloud's axes.
    dip, dip_direction : (S,) arrays
        Each set's mean orientation (degrees).
    n_planes, area : (S,) arrays
        The planes in each set and their total area.
    resultant, fisher_k, alpha95, spherical_variance : (S,) arrays
        Fisher's R and K, the 95% cone of confidence (degrees) and the spherical variance.
    criterion : str
        How the number of sets was chosen (``bic``, or ``given``).
    bic : dict
        The BIC of each number of sets tried.

    Examples
    --------
    >>> from geostructure.synthetic import fisher_directions
    >>> rng = np.random.default_rng(1)
    >>> normals = np.vstack([fisher_directions([0.0, -0.7, 0.7], 80.0, 60, rng),
    ...                      fisher_directions([0.7, 0.0, 0.7], 80.0, 60, rng)])
    >>> sets = find_sets(normals, n_sets=2)
    >>> len(sets), bool(np.all(np.abs(sets.dip - 45.0) < 3.0)), sets.labels.shape
    (2, True, (120,))
    """

    labels: np.ndarray
    mean_normal: np.ndarray  # (S, 3) upward unit, cloud axes
    dip: np.ndarray
    dip_direction: np.ndarray
    n_planes: np.ndarray
    area: np.ndarray
    resultant: np.ndarray  # Fisher's R
    fisher_k: np.ndarray
    alpha95: np.ndarray  # degrees
    spherical_variance: np.ndarray
    criterion: str = "given"
    bic: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.dip)

    def rows(self) -> list[dict]:
        """One dict per set, as ``sets.csv`` holds them."""
        return [
            {
                "set": i,
                "n_planes": int(self.n_planes[i]),
                "area_m2": float(self.area[i]),
                "dip": float(self.dip[i]),
                "dip_direction": float(self.dip_direction[i]),
                "strike": float((self.dip_direction[i] - 90.0) % 360.0),
                "fisher_k": float(self.fisher_k[i]),
                "alpha95_deg": float(self.alpha95[i]),
                "spherical_variance": float(self.spherical_variance[i]),
                "normal_x": float(self.mean_normal[i, 0]),
                "normal_y": float(self.mean_normal[i, 1]),
                "normal_z": float(self.mean_normal[i, 2]),
            }
            for i in range(len(self))
        ]


def fisher_statistics(normals, frame: Frame = Frame()) -> dict:
    """Fisher (1953) statistics of one set of plane normals, taken as axes.

    Examples
    --------
    >>> from geostructure.synthetic import fisher_directions
    >>> rng = np.random.default_rng(0)
    >>> poles = fisher_directions([1.0, 0.0, 0.02], 50.0, 400, rng)  # steep planes facing east
    >>> poles[rng.random(400) < 0.5] *= -1  # either sign, as measured poles come
    >>> stats = fisher_statistics(poles)
    >>> bool(abs(stats["dip"] - 88.85) < 2 * stats["alpha95"]), round(stats["dip_direction"]) % 180
    (True, 90)
    >>> bool(40 < stats["fisher_k"] < 60)  # drawn with kappa 50
    True
    """
    x = _unit(normals)
    n = len(x)
    if n == 0:
        raise ParameterError("fisher_statistics needs at least one normal.")
    mean = _principal_axes(_outer(x), np.ones((1, n)))[0]
    mean = mean if frame.to_enu(mean)[2] >= 0 else -mean
    aligned = x * np.where(x @ mean < 0, -1.0, 1.0)[:, None]
    r = float(np.linalg.norm(aligned.sum(axis=0)))
    k = (n - 1) / (n - r) if n > 1 and n - r > 1e-12 else np.inf
    if n > 1 and r > 0:
        cos_alpha = 1.0 - (n - r) / r * (20.0 ** (1.0 / (n - 1)) - 1.0)
        alpha95 = float(np.degrees(np.arccos(np.clip(cos_alpha, -1.0, 1.0))))
    else:
        alpha95 = float("nan")
    o = orientation_from_normals(mean, frame)
    return {
        "mean_normal": mean,
        "dip": float(o.dip[0]),
        "dip_direction": float(o.dip_direction[0]),
        "n": n,
        "resultant": r,
        "fisher_k": float(k),
        "alpha95": alpha95,
        "spherical_variance": 1.0 - r / n,
    }


def find_sets(
    normals,
    weights=None,
    *,
    n_sets: int | None = None,
    max_sets: int = MAX_SETS,
    frame: Frame = Frame(),
    seed: int = 0,
    centroids=None,
) -> JointSets:
    """Cluster plane normals (cloud axes) into joint sets; ``n_sets=None`` chooses by BIC.

    Parameters
    ----------
    normals : (P, 3) array
        The planes' normals; their sign does not matter.
    weights : (P,) array, optional
        Each plane's weight in the clustering (its area); equal by default.
    n_sets : int, optional
        The number of sets; chosen by BIC among 1 to ``max_sets`` when not given.
    frame : Frame
        For the sets' dip and dip direction.
    seed : int
        The EM's starts are drawn from this seed, so a run is repeatable.
    centroids : (P, 3) array, optional
        The planes' centroids. When given with ``weights`` (their areas), a number of sets is
        chosen only if each of its sets holds :data:`MIN_SET_JOINTS` joints or more, facets on
        one plane counting as one joint (:func:`~geostructure.rockmass.joints.joint_planes`): the facets of a
        single joint drawn far from its set's mean are that joint, not a set.

    Returns
    -------
    JointSets
        Each plane's set (``labels``, -1 for none) and per set its mean, Fisher's K,
        alpha95 and spherical variance; ``bic`` per number of sets tried.

    Examples
    --------
    >>> from geostructure.synthetic import fisher_directions
    >>> rng = np.random.default_rng(1)
    >>> a = fisher_directions([0.0, -0.7, 0.7], 80.0, 150, rng)
    >>> b = fisher_directions([0.7, 0.0, 0.7], 80.0, 100, rng)
    >>> sets = find_sets(np.vstack([a, b]))
    >>> len(sets), sets.n_planes.tolist(), sets.criterion
    (2, [150, 100], 'bic')
    """
    x = _unit(normals)
    if not len(x):  # no plane: no set (the weights' mean below would be 0 / 0)
        return _empty(0)
    w = np.ones(len(x)) if weights is None else np.asarray(weights, dtype=np.float64).reshape(len(x))
    if not np.all(np.isfinite(w)) or (w < 0).any():
        raise ParameterError("set weights must be finite and not negative.")
    area = np.where(w > 0, w, 0.0)
    # The EM sees weights of mean 1, so the likelihood (and BIC) counts planes, not square metres.
    w = area * (len(x) / area.sum()) if area.sum() > 0 else np.ones(len(x))
    if n_sets is not None and (int(n_sets) != n_sets or n_sets < 1):
        raise ParameterError(f"`n_sets` must be a whole number of at least 1, got {n_sets!r}.")
    rng = np.random.default_rng(seed)
    n_eff = float(w.sum() ** 2 / (w**2).sum())  # Kish's effective number of planes
    if n_sets is not None:
        candidates = [int(n_sets)]
    else:
        candidates = list(range(1, max(1, min(max_sets, len(x) // MIN_SET_PLANES)) + 1))
    fits: dict[int, dict] = {}
    bic: dict[int, float] = {}
    holds: dict[int, bool] = {}
    count_joints = (
        joint_counter(x, np.asarray(centroids, dtype=np.float64).reshape(len(x), 3), area, MIN_SET_JOINTS)
        if centroids is not None and weights is not None
        else None
    )

    def holds_its_joints(k: int) -> bool:  # each set MIN_SET_JOINTS joints or more (counted once per k)
        if count_joints is None:
            return True
        if k not in holds:
            holds[k] = min(count_joints(_assign(x, fits[k]), k)) >= MIN_SET_JOINTS
        return holds[k]

    for k in candidates:
        if len(x) < k * MIN_SET_PLANES:
            continue
        # EM finds a local optimum: keep the best of a few starts.
        # One set's starts are all the heaviest pole: one start is all of them.
        fits[k] = _fit_mixture(x, w, k, rng, starts=EM_STARTS if k > 1 else 1)
        # Weighted, the log-likelihood counts the planes n / n_eff times over: scale it back.
        bic[k] = -2.0 * fits[k]["loglik"] * n_eff / len(x) + (3 * k + k) * np.log(max(n_eff, 2.0))
        # BIC risen twice running past a fit that would be chosen: more sets only split sets
        # (on a 40 x 16 m face of three sets, the fits of 4 to 6 sets were 95% of the time).
        last = sorted(bic)[-3:]
        if n_sets is None and len(last) == 3 and bic[last[2]] > bic[last[1]] > bic[last[0]]:
            best = min(bic, key=bic.__getitem__)
            if _separated(fits[best]["means"], MIN_SEPARATION) and holds_its_joints(best):
                break
    if not fits:
        if n_sets is not None:
            warnings.warn(
                f"{len(x)} {'plane makes' if len(x) == 1 else 'planes make'} at most "
                f"{len(x) // MIN_SET_PLANES} {'set' if len(x) // MIN_SET_PLANES == 1 else 'sets'} of "
                f"{MIN_SET_PLANES} planes, not the {n_sets} asked for: no set was fitted; ask for fewer, or leave the "
                f"number to BIC.",
                GeoStructureWarning,
                stacklevel=2,
            )
        return _empty(len(x))
    admissible = sorted((k for k in bic if _separated(fits[k]["means"], MIN_SEPARATION)), key=bic.__getitem__)
    if count_joints is not None:
        # Tried from the smallest BIC up, the first that passes is the choice: counting the
        # joints of the others would not change it.
        admissible = next(([k] for k in admissible if holds_its_joints(k)), [])
    best = (admissible[0] if admissible else min(bic, key=bic.__getitem__)) if n_sets is None else candidates[0]
    labels = _assign(x, fits[best])
    found = _summarise(x, area, labels, frame, "bic" if n_sets is None else "given", bic)
    if n_sets is not None and len(found) < n_sets:
        warnings.warn(
            f"{len(found)} of the {n_sets} sets asked for hold {MIN_SET_PLANES} planes or more; the planes of the "
            f"others are left in no set.",
            GeoStructureWarning,
            stacklevel=2,
        )
    return found


def _separated(means: np.ndarray, degrees: float) -> bool:
    """Whether every two axes are at least ``degrees`` apart."""
    if len(means) < 2:
        return True
    cosine = np.abs(means @ means.T)[np.triu_indices(len(means), 1)]
    return bool(np.all(cosine <= np.cos(np.radians(degrees))))


def _unit(normals) -> np.ndarray:
    x = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    length = np.linalg.norm(x, axis=1, keepdims=True)
    if not np.all(np.isfinite(x)) or (length == 0).any():
        raise ParameterError("normals must be finite and non-zero.")
    return x / length


def _outer(x: np.ndarray) -> np.ndarray:
    """(P, 9): each axis's x x^T, flattened, for :func:`_principal_axes`."""
    return (x[:, :, None] * x[:, None, :]).reshape(len(x), 9)


def _principal_axes(outer: np.ndarray, rw: np.ndarray) -> np.ndarray:
    """(..., K, 3): principal eigenvector of each component's weighted orientation tensor
    sum(w x x^T), ``rw`` (..., K, P) holding the weights and ``outer`` the axes'
    :func:`_outer`; one batched eigh for all."""
    return np.linalg.eigh((rw @ outer).reshape(*rw.shape[:-1], 3, 3))[1][..., -1]


def _log_bipolar_fisher(x: np.ndarray, means: np.ndarray, kappas: np.ndarray) -> np.ndarray:
    """(..., K, P): log f(x) for each component, f = kappa / (4 pi sinh kappa) cosh(kappa
    mean.x), overflow-free; ``means`` (..., K, 3) and ``kappas`` (..., K)."""
    c = np.abs(np.asarray(means) @ x.T)
    kappas = np.asarray(kappas, dtype=np.float64)[..., None]
    # log cosh(k c) - log sinh(k) = k (c - 1) + log(1 + e^{-2kc}) - log(1 - e^{-2k})
    return (
        np.log(kappas / (4.0 * np.pi))
        + kappas * (c - 1.0)
        + np.log1p(np.exp(-2.0 * kappas * c))
        - np.log1p(-np.exp(-2.0 * kappas))
    )


def _kappas(r_bar: np.ndarray) -> np.ndarray:
    """Concentrations from the mean resultant lengths (Banerjee et al. 2005), bounded."""
    r_bar = np.clip(r_bar, 1e-6, 1.0 - 1e-9)
    return np.clip(r_bar * (3.0 - r_bar**2) / (1.0 - r_bar**2), 1e-3, MAX_KAPPA)


def _component_log_p(x: np.ndarray, means, kappas, mix) -> np.ndarray:
    """(..., K + 1, P): log of each component's weighted density, the uniform one last.

    Components are the second last axis: the reductions over them run along an outer
    axis, which numpy does row by row, several times faster on short axes than along the
    last."""
    fisher = _log_bipolar_fisher(x, means, kappas)
    uniform = np.full((*fisher.shape[:-2], 1, len(x)), -np.log(4 * np.pi))
    return np.concatenate([fisher, uniform], axis=-2) + np.log(np.maximum(mix, 1e-300))[..., None]


def _fit_mixture(x: np.ndarray, w: np.ndarray, k: int, rng, starts: int = 1, iterations: int = 200) -> dict:
    """EM for ``k`` bipolar Fisher components and a uniform one from ``starts`` k-means++-like
    starts, run side by side (an axis of their own, each stopping when it converges); the
    fit of the highest likelihood, the first such on a tie."""
    # Starts: the heaviest pole, then each next the pole farthest (axially) from those chosen.
    means = np.empty((starts, k, 3))
    for s in range(starts):
        chosen = [x[int(np.argmax(w))]]
        for _ in range(1, k):
            closeness = np.max(np.abs(x @ np.array(chosen).T), axis=1)
            p = w * (1.0 - closeness) ** 2 + 1e-12
            chosen.append(x[rng.choice(len(x), p=p / p.sum())])
        means[s] = chosen
    kappas = np.full((starts, k), 20.0)
    mix = np.full((starts, k + 1), 1.0 / (k + 1))
    loglik, outer = np.full(starts, -np.inf), _outer(x)
    running = np.arange(starts)  # the starts not yet converged
    for iteration in range(iterations):
        log_p = _component_log_p(x, means[running], kappas[running], mix[running])
        top = log_p.max(axis=1)
        total = top + np.log(np.exp(log_p - top[:, None]).sum(axis=1))
        rw = np.exp(log_p - total[:, None]) * w  # responsibilities times weights, (A, K + 1, P)
        new = np.array([float(w @ t) for t in total])  # one dot each: the same sum as alone
        held = rw.sum(axis=2)
        mix[running] = held / held.sum(axis=1, keepdims=True)
        # Every component's axis and kappa, kept where it holds something (an empty one
        # keeps its mean and kappa). A stack of products and eigh's are each start's own
        # calls: the same numbers as the starts run one by one.
        fitted = _principal_axes(outer, rw[:, :k])
        r_bar = (rw[:, :k] * np.abs(fitted @ x.T)).sum(axis=2) / np.where(held[:, :k] > 0, held[:, :k], 1.0)
        live = held[:, :k] > 1e-9
        means[running] = np.where(live[..., None], fitted, means[running])
        kappas[running] = np.where(live, _kappas(r_bar), kappas[running])
        change = new - loglik[running]
        done = change < 1e-6 * np.abs(new)
        loglik[running] = new
        # A start creeping up a poor optimum (the over-split fits of four sets and more can
        # gain 0.02 a step for the whole 200) is left where it is once, gaining at its
        # present rate for every step left, it would still end below the best start: EM's
        # gains shrink as it converges. The margin covers the best start's own last wobble.
        reach = new + change * (iterations - 1 - iteration)
        hopeless = reach < loglik.max() - HOPELESS_MARGIN
        running = running[~(done | hopeless)]
        if not len(running):
            break
    best = int(np.argmax(loglik))
    return {"means": means[best], "kappas": kappas[best], "mix": mix[best], "loglik": float(loglik[best])}


def _assign(x: np.ndarray, fit: dict) -> np.ndarray:
    """Each pole's most likely component; the uniform one (no set) gives -1."""
    k = len(fit["means"])
    best = np.argmax(_component_log_p(x, fit["means"], fit["kappas"], fit["mix"]), axis=0)
    return np.where(best == k, -1, best)


def _summarise(x, area, labels, frame, criterion, bic) -> JointSets:
    """Sets of at least MIN_SET_PLANES planes, numbered by decreasing total area."""
    sets = [j for j in range(int(labels.max(initial=-1)) + 1) if (labels == j).sum() >= MIN_SET_PLANES]
    totals = np.array([area[labels == j].sum() for j in sets])
    rank = np.argsort(-totals, kind="stable")
    order = [sets[i] for i in rank]
    renumber = np.full(int(labels.max(initial=-1)) + 2, -1)
    renumber[order] = np.arange(len(order))
    stats = [fisher_statistics(x[labels == j], frame) for j in order]
    return JointSets(
        labels=renumber[labels],
        mean_normal=np.array([s["mean_normal"] for s in stats]).reshape(-1, 3),
        dip=np.array([s["dip"] for s in stats]),
        dip_direction=np.array([s["dip_direction"] for s in stats]),
        n_planes=np.array([s["n"] for s in stats], dtype=np.int64),
        area=totals[rank] if len(sets) else np.zeros(0),
        resultant=np.array([s["resultant"] for s in stats]),
        fisher_k=np.array([s["fisher_k"] for s in stats]),
        alpha95=np.array([s["alpha95"] for s in stats]),
        spherical_variance=np.array([s["spherical_variance"] for s in stats]),
        criterion=criterion,
        bic={int(k): float(v) for k, v in bic.items()},
    )


def _empty(n: int) -> JointSets:
    z = np.zeros(0)
    return JointSets(np.full(n, -1), np.zeros((0, 3)), z, z, np.zeros(0, int), z, z, z, z, z)
