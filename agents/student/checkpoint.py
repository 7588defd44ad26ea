"""The student's first round (round 0 of ``distill``), kept so that an interrupted student stage
resumes after it instead of labelling and fitting it again (on the shipped recipe: about 560 of the
stage's 730 s).

A checkpoint is written twice in round 0: once its teacher's episodes are labelled (the episodes,
no weights yet, ``"fitted": false``), so that a stage interrupted during the fit resumes at the fit
instead of labelling again, and once it is fitted. A fitted checkpoint holds the student's weights
and observation statistics after round 0, the episodes gathered so far, the state of the random
generator that draws the later rounds' points, round 0's record and a fingerprint of everything
round 0 depended on: the teacher's field, the student's seed, the env keywords, the PPO settings
and every distillation setting but those only later rounds read (``LATER_ROUND_KEYS``).
Continuing from either gives the weights an uninterrupted run gives (tested). A checkpoint whose
fingerprint differs is not used: round 0 is labelled and fitted again and the checkpoint replaced.
The file is data only (an ``.npz`` of arrays and one JSON text, read with
``allow_pickle=False``): reading it runs no code.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import zipfile
from pathlib import Path

import numpy as np

from mdr_drive_env.files import atomic_path

#: DistillConfig fields that round 0 does not read: a checkpoint serves runs that differ in them.
LATER_ROUND_KEYS = frozenset({"rounds", "round_steps", "hole_rounds", "hole_probes", "hole_shortfall", "hole_floor",
                              "hole_neighbours", "hole_steps", "hole_learning_rate", "hole_dagger", "stall_probes",
                              "stall_band"})


def field_digest(field_) -> str:
    """SHA-256 of a teacher's arrays (a ``DriveField``, or each field of a ``FrictionField``)."""
    digest = hashlib.sha256()
    for sub in getattr(field_, "fields", [field_]):
        for name in ("ks", "fractions", "trapezoid_critical", "drives", "velocities", "point_at", "point_drives"):
            digest.update(np.ascontiguousarray(getattr(sub, name), dtype=np.float64).tobytes())
        digest.update(repr(sub.friction).encode())
    return digest.hexdigest()


def fingerprint(field_, config, seed: int, env_kwargs: dict, hyperparameters: dict, friction=None) -> dict:
    """What round 0 of ``distill`` depended on, as plain JSON values (``config``: a DistillConfig)."""
    round0 = {key: value for key, value in dataclasses.asdict(config).items() if key not in LATER_ROUND_KEYS}
    return json.loads(json.dumps({"teacher": field_digest(field_), "seed": int(seed), "distill": round0,
                                  "env_kwargs": env_kwargs, "hyperparameters": hyperparameters,
                                  "friction": friction}, default=float))


def save(path: str | Path, student, rng: np.random.Generator, obs_all: list, drive_all: list, record: dict,
         fingerprint_: dict, fitted: bool = True) -> None:
    """Write the checkpoint after round 0 (atomically; arrays and one JSON text); with ``fitted``
    False, after its episodes are labelled and before the fit: no weights, and ``record`` holds what
    the labelling recorded (its jump points and wall time)."""
    arrays = ({f"policy/{name}": tensor.detach().cpu().numpy()
               for name, tensor in student.model.policy.state_dict().items()} if fitted else {})
    arrays.update({f"obs/{i}": np.asarray(a) for i, a in enumerate(obs_all)})
    arrays.update({f"drives/{i}": np.asarray(a) for i, a in enumerate(drive_all)})
    rms = student.venv.obs_rms
    arrays.update({"obs_rms/mean": np.asarray(rms.mean), "obs_rms/var": np.asarray(rms.var)})
    meta = {"fingerprint": fingerprint_, "rng": rng.bit_generator.state, "record": record,
            "obs_rms_count": float(rms.count), "episodes": len(obs_all), "fitted": bool(fitted)}
    arrays["meta"] = np.array(json.dumps(meta, default=float))
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)


def load(path: str | Path, fingerprint_: dict) -> tuple[dict | None, str]:
    """The checkpoint at ``path`` if it was written for ``fingerprint_``, and why not otherwise
    (``(None, reason)``; no file is not a reason: ``(None, "")``)."""
    path = Path(path)
    if not path.exists():
        return None, ""
    try:
        with np.load(path, allow_pickle=False) as f:
            state = {key: f[key] for key in f.files}
        meta = json.loads(str(state.pop("meta")))
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as e:  # a truncated or foreign file: fit again
        return None, f"{path} is not a round-0 checkpoint ({type(e).__name__})"
    saved = meta.get("fingerprint") if isinstance(meta, dict) else None
    if saved is None:
        return None, f"{path} has no fingerprint (not a student checkpoint)"
    if saved != fingerprint_:
        differ = sorted(key for key in fingerprint_ if saved.get(key) != fingerprint_[key])
        if "distill" in differ:
            differ[differ.index("distill")] = "distill: " + ", ".join(
                sorted(k for k, v in fingerprint_["distill"].items() if saved.get("distill", {}).get(k) != v))
        return None, f"{path} was fitted with another {'; '.join(differ)}"
    return {"meta": meta, "arrays": state}, ""


def is_fitted(state: dict) -> bool:
    """Whether a checkpoint read by :func:`load` holds round 0's fit (else only its labelled episodes)."""
    return bool(state["meta"].get("fitted", True))  # checkpoints from before the labelled stage: fitted


def restore(state: dict, student, rng: np.random.Generator) -> tuple[list, list, dict]:
    """Put a checkpoint's weights (a fitted one's), observation statistics and generator state into
    ``student`` and ``rng``; returns its episodes (observations, drives) and its record (round 0's,
    or what the labelling recorded)."""
    import torch

    meta, arrays = state["meta"], state["arrays"]
    if is_fitted(state):
        student.model.policy.load_state_dict({name[len("policy/"):]: torch.from_numpy(value)
                                              for name, value in arrays.items() if name.startswith("policy/")})
    rms = student.venv.obs_rms
    rms.mean, rms.var, rms.count = arrays["obs_rms/mean"], arrays["obs_rms/var"], meta["obs_rms_count"]
    rng.bit_generator.state = meta["rng"]
    episodes = range(meta["episodes"])
    return [arrays[f"obs/{i}"] for i in episodes], [arrays[f"drives/{i}"] for i in episodes], dict(meta["record"])
