"""The student: a plain SB3 PPO policy distilled from the teacher's drive field by DAgger.

The student is an ``MlpPolicy`` on the env's own 14 observations, normalised by a ``VecNormalize``
whose statistics are those of the observations it was trained on; at play time nothing but the
network acts (``PPO.load`` + ``VecNormalize.load`` + ``model.predict``). Training (Ross et al. 2011):

1. round 0: the teacher plays its drives at random (k, load) points of the training domain; every
   observation is recorded with the teacher's action there;
2. rounds 1 ... R: the student plays at fresh random points; every observation it meets is
   labelled with the action the teacher would play next (the teacher's drive at that episode's
   (k, load), in the cycle phase that follows the student's previous action: ``cycle_action``);
   the student is refitted on everything gathered so far;
3. hole rounds 1 ... H: the student and the teacher each drive at fresh random points; where the
   student falls short of the teacher (``find_holes``), the teacher plays more episodes at and
   around those points (with ``hole_dagger``, the student's own episodes there too, labelled by the
   teacher), they are added, and the fit continues. A network fitted to a teacher whose
   drive jumps between optima is wrong in patches near the jumps, and where the patches fall
   changes from run to run with the fit's round-off: these rounds look for them and fill them.

The teacher's drive at an episode's point is the best of the field's interpolation and its
surrounding grid drives played at that very point (``DriveField.best``). The fit is a squared
error on the policy's mean action, except that where the teacher's action lies on the box's edge
an output beyond the edge costs nothing (SB3 clips the action to the box when acting): the
optimal drives use the full stroke or depth in most components, and only the others need to be
precise (the steady velocity near an optimal drive changes steeply with the action).

With ``action_codebook`` the student picks instead of regressing: its action is an index into the
teacher grid's distinct actions (``Discrete(N)``; the env's ``action_codebook``), fitted by
cross-entropy, and the teacher plays only the grid's own drives, so the student plays one of two
neighbouring drives where the teacher's jumps, never a blend of them.

The points and the episodes the student is taught on: ``mdr_drive_agents.student.data``; the
network, its loss and its Adam fit: ``mdr_drive_agents.student.network``; round 0 kept for
``--resume``: ``mdr_drive_agents.student.checkpoint``.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_bool, check_int, check_range
from mdr_drive_env.gym_envs.spaces import ObservationLayout, shift_phase_origin

from ..cycles import cycle_action
from ..protocol import steady_velocity_of
from ..teacher import DriveField, LoadBand
from ..teacher.load_band import check_load_factors
from . import checkpoint as round0_checkpoint
from .data import (around, clipped_k_range, draw_points, grid_actions, jump_points, labelled_episodes,
                   perturb_previous_actions, rollout, stall_points, teacher_drives)
from .network import Student, adam_fit, edge_loss, make_student, policy_logits, policy_mean, policy_raw_logits


#: Round 0's extra-episode bands: (count field, k-interval field) of :class:`DistillConfig`, in drawing order.
FOCUS_KEYS = (("focus_points", "focus_k"), ("inner_focus_points", "inner_focus_k"))


@dataclass(frozen=True)
class DistillConfig:
    """DAgger distillation of the drive field into a PPO MlpPolicy.

    Attributes:
        net_arch: hidden layer sizes of the policy network (the value network keeps SB3's 64, 64).
        activation: ``"relu"`` or ``"tanh"``.
        points: random (k, load) episodes the teacher plays (-).
        periods: periods per episode of the rollouts (-).
        no_load_share: share of the points without load (-).
        load_factor: loads are drawn up to this times the trapezoid's critical load (-).
        steps: gradient steps of the fit on the teacher's episodes (-).
        rounds: DAgger rounds after it: the student plays ``points`` new episodes, they are added,
            and the fit continues for ``round_steps`` (-).
        round_steps: gradient steps per DAgger round (-).
        batch: minibatch size (-).
        learning_rate: Adam step size, decaying linearly to zero over each fit (-).
        perturbed_share: share of the samples whose previous action is perturbed in each epoch (-).
        log_std: the policy's log standard deviation after distillation (for PPO fine-tuning) (-).
        torch_threads: torch threads of the fit (-).
        bf16_share: share of each fit's Adam steps (the first ones) whose matrix products run in
            bfloat16 (``torch.autocast``; the weights, the optimiser and the last steps stay float32):
            faster on CPUs with AVX-512 BF16 or AMX, slower on CPUs without (0: off) (-).
        fused_adam: torch's fused Adam (one pass over the weights a step; the same update up to
            rounding, so other weights than the default's) (-).
        flush_denormal: the fits run with denormal floats flushed to zero (``adam_fit``). A codebook
            student's softmax over a large table (``action_codebook``) grows confident during the
            fit: the gradients and Adam's second moments of the rows it rules out fall below
            float32's smallest normal number, and CPU arithmetic on such numbers is many times
            slower, so the fit slows as it converges. Flushing keeps its speed and changes the
            weights only where values that small are rounded to zero (so other weights than the
            default's) (-).
        hole_rounds: rounds that look for where the student falls short of the teacher and add the
            teacher's episodes there (module docstring) (-).
        hole_probes: random points per hole round where the student and the teacher drive (-).
        hole_shortfall: a probe is a hole where the student's steady velocity is below the
            teacher's by more than this fraction of it, and by more than ``hole_floor`` (-).
        hole_floor: ... and by more than this (m/s). Near its critical load at high k the teacher
            moves at under 1 mm/s, so with a floor of 1 mm/s no probe there can be a hole.
        hole_neighbours: teacher episodes added at jittered points around each hole, besides the
            hole itself (k +- 0.01, load +- 5 %) (-).
        hole_steps: gradient steps after each hole round (-).
        hole_learning_rate: Adam step size of those steps, decaying linearly to zero (-).
        hole_dagger: each hole round also adds the student's own episodes at the same points,
            every observation labelled with the teacher's next action there (DAgger at the holes):
            the states a student meets when it alternates between two neighbouring drives are not
            on the teacher's trajectories, so the teacher's episodes alone do not label them.
        stall_probes: besides, points per hole round at loads just around the teacher's stall
            (``stall_points``), where the critical load is judged; there a probe where the teacher
            moves and the student does not is a hole too, however slow the teacher (-).
        stall_band: those probes' loads, as fractions of the teacher's stall load at their k (-).
        huber_delta: 0 fits the squared error; > 0 the Huber loss with this threshold (``edge_loss``)
            (action units).
        teacher_radius: the grid neighbourhood whose drives the teacher plays at a point besides
            the interpolation (``DriveField.best``): 1 the cell's four corners, R the 2R x 2R nodes
            around it (-).
        jump_levels: bisection levels of ``jump_points`` after round 0's teacher episodes: where
            neighbouring points' teacher drives differ, the midpoint's episodes are added, and the
            half holding the jump is bisected again (0: off) (-).
        jump_neighbours: neighbours of each round 0 point that ``jump_points`` compares it with (-).
        jump_threshold: two teacher drives differ where a component differs by more than this, in
            their closest cycle phase (action units).
        focus_points: round 0's extra random episodes with k in ``focus_k`` (loads drawn as for
            ``points``), so the fit sees that band more densely (0: none) (-).
        focus_k: the k interval of those episodes (-).
        inner_focus_points, inner_focus_k: a second such band, drawn after the first (usually a
            narrower one inside it, where the misses still sit) (0: none) (-).
        quantum_centres: label the student with the teacher's actions moved to the centre of the time
            quantum their rise fractions and z phase select (``ActionMap.quantum_centre``): the
            same drives, and an error of up to half a quantum (0.0056 action units for a rise,
            0.005 for the phase) leaves the waveform unchanged; a rise in the box's first or last
            quantum becomes the edge itself, past which the fit lets the output go. Near stall one
            quantum changes the steady velocity by more than a mm/s.
        action_codebook: the student picks whole actions instead of regressing one: its action space
            is ``Discrete(N)`` over the teacher grid's N distinct actions (``grid_actions``, the
            env's ``action_codebook``), its output a softmax over them fitted by cross-entropy, and
            it plays the most likely one; the teacher plays the grid's own drives only
            (``teacher_drives``). Where the teacher's drive jumps between two families, a regression
            plays a blend of the two for a narrow band of (k, load) that can go backwards; a pick
            plays one or the other. Needs ``quantum_centres`` (the labels are the table's rows).
        raw_logits: a codebook student's cross-entropy on the action net's raw output
            (``policy_raw_logits``) instead of SB3's normalised logits: the same loss up to rounding,
            so other weights than without it, at about half the cost of a fit step. Needs
            ``action_codebook``.
        teacher_load_radius: the load lines of the teacher's neighbourhood (``DriveField.candidates``'s
            ``load_radius``): R plays the 2R load lines around the point's cell (0: ``teacher_radius``).
            Where ``refine_band`` halved the load spacing, 3 reaches as far in load as 2 did (-).
        teacher_load_band: load factors (-) over which the teacher's pick must hold, e.g. [0.92,
            1.08] (``LoadBand``): each candidate is scored by its worst ratio to the fastest
            candidate at the point's load times each factor, so a student that reads the load to
            about 8 % is taught drives that do not fall off a critical load of their own within
            that error; () picks the fastest at the point. Costs one more play of every
            candidate per factor.
        teacher_load_loss: the most such a pick may lose at the point itself against the fastest
            candidate there (-).
    """

    net_arch: tuple[int, ...] = (512, 512, 512)
    activation: str = "relu"
    points: int = 4096
    periods: int = 8
    no_load_share: float = 0.1
    load_factor: float = 1.7
    steps: int = 60_000
    rounds: int = 0
    round_steps: int = 10_000
    batch: int = 256
    learning_rate: float = 1e-3
    perturbed_share: float = 0.5
    log_std: float = -3.0
    torch_threads: int = 1
    bf16_share: float = 0.0
    fused_adam: bool = False
    flush_denormal: bool = False
    teacher_radius: int = 1
    hole_rounds: int = 0
    hole_probes: int = 4096
    hole_shortfall: float = 0.1
    hole_floor: float = 1e-3
    hole_neighbours: int = 8
    hole_steps: int = 10_000
    hole_learning_rate: float = 3e-4
    hole_dagger: bool = False
    stall_probes: int = 0
    stall_band: tuple[float, float] = (0.92, 1.02)
    huber_delta: float = 0.0
    jump_levels: int = 0
    jump_neighbours: int = 6
    jump_threshold: float = 0.3
    quantum_centres: bool = False
    focus_points: int = 0
    focus_k: tuple[float, float] = (0.0, 0.6)
    inner_focus_points: int = 0
    inner_focus_k: tuple[float, float] = (0.0, 0.6)
    action_codebook: bool = False
    raw_logits: bool = False
    teacher_load_radius: int = 0
    teacher_load_band: tuple[float, ...] = ()
    teacher_load_loss: float = 0.1

    def __post_init__(self) -> None:
        if self.activation not in ("relu", "tanh"):
            raise ValueError(f"activation={self.activation!r} is not one of ['relu', 'tanh']")
        for name in ("points", "periods", "steps", "rounds", "round_steps", "batch", "torch_threads", "teacher_radius",
                     "hole_rounds", "hole_probes", "hole_neighbours", "hole_steps", "jump_levels", "jump_neighbours",
                     "stall_probes", "focus_points", "inner_focus_points", "teacher_load_radius"):
            check_int(name, getattr(self, name),
                      0 if name in ("rounds", "hole_rounds", "hole_neighbours", "jump_levels", "stall_probes",
                                   "focus_points", "inner_focus_points", "teacher_load_radius") else 1)
        if not self.net_arch or not all(isinstance(n, int) and n >= 1 for n in self.net_arch):
            raise ValueError(f"net_arch={self.net_arch!r} must be positive layer sizes")
        check_range("no_load_share", self.no_load_share, 0.0, 1.0)
        check_range("perturbed_share", self.perturbed_share, 0.0, 1.0)
        check_range("bf16_share", self.bf16_share, 0.0, 1.0)
        check_range("load_factor", self.load_factor, 0.0, 5.0, low_open=True)
        check_range("learning_rate", self.learning_rate, 0.0, 1.0, low_open=True)
        check_range("hole_learning_rate", self.hole_learning_rate, 0.0, 1.0, low_open=True)
        check_range("hole_shortfall", self.hole_shortfall, 0.0, 1.0, low_open=True)
        check_range("hole_floor", self.hole_floor, 0.0, 0.01)
        if len(self.stall_band) != 2:
            raise ValueError(f"stall_band={self.stall_band!r} must be two fractions [low, high]")
        check_range("stall_band[0]", self.stall_band[0], 0.0, 2.0, low_open=True)
        check_range("stall_band[1]", self.stall_band[1], self.stall_band[0], 2.0, low_open=True)
        check_range("huber_delta", self.huber_delta, 0.0, 2.0)
        check_range("jump_threshold", self.jump_threshold, 0.0, 2.0, low_open=True)
        for _, name in FOCUS_KEYS:
            band = getattr(self, name)
            if len(band) != 2:
                raise ValueError(f"{name}={band!r} must be two values of k [low, high]")
            check_range(f"{name}[0]", band[0], 0.0, 1.0)
            check_range(f"{name}[1]", band[1], band[0], 1.0, low_open=True)
        for name in ("quantum_centres", "hole_dagger", "fused_adam", "flush_denormal", "action_codebook", "raw_logits"):
            check_bool(name, getattr(self, name))
        if self.raw_logits and not self.action_codebook:
            raise ValueError("raw_logits=true needs action_codebook=true (a regression student has no logits)")
        check_range("teacher_load_loss", self.teacher_load_loss, 0.0, 1.0, high_open=True)
        check_load_factors("teacher_load_band", self.teacher_load_band)
        if self.action_codebook and not self.quantum_centres:
            raise ValueError("action_codebook=true needs quantum_centres=true (the labels must be the codebook's rows)")

    def load_band(self) -> LoadBand | None:
        """The teacher's ``LoadBand`` (None without ``teacher_load_band``)."""
        if not self.teacher_load_band:
            return None
        return LoadBand(tuple(float(s) for s in self.teacher_load_band), max_loss=float(self.teacher_load_loss))

    def focus_bands(self) -> list[tuple[int, tuple[float, float]]]:
        """Round 0's extra episodes: (points, (k low, k high)) per band in use, in drawing order."""
        return [(getattr(self, count), tuple(getattr(self, band))) for count, band in FOCUS_KEYS if getattr(self, count)]


def epoch_samples(obs: np.ndarray, drives: np.ndarray, rng: np.random.Generator,
                  perturbed_share: float) -> tuple[np.ndarray, np.ndarray]:
    """One epoch's inputs and labels from the teacher's episodes ``obs`` (n, 14 or 15) and each
    sample's drive ``drives`` (n, 2, 5): a ``perturbed_share`` of the previous actions replaced
    (``perturb_previous_actions``), each entry of the slider's motion and the episode's elapsed
    fraction taken from another sample (the teacher's action does not depend on them, and with the
    entries as recorded the student read the drive off the slider's velocity, which its own drive
    then changed), and the label: the action each drive plays after that previous action
    (``cycle_action``). Returns the inputs (unnormalised, float) and labels (n, 5)."""
    structure = ObservationLayout.structure  # the privileged layout has the same entries first
    prev_slice = structure["previous_action"]
    x = perturb_previous_actions(obs, drives, rng, perturbed_share, prev_slice)
    y = cycle_action(drives, x[:, prev_slice])
    for column in [*range(*structure["dynamics"].indices(obs.shape[1])),
                   *range(*structure["episode_fraction"].indices(obs.shape[1]))]:
        x[:, column] = x[rng.permutation(len(x)), column]
    return x, y


def fit(student: Student, obs: np.ndarray, drives: np.ndarray, steps: int, config: DistillConfig, seed: int,
        progress: bool = True, learning_rate: float | None = None) -> float:
    """Fit the student's mean action to the teacher's (``cycle_action`` of each sample's drive after
    its previous action) on normalised ``obs``, ``steps`` Adam steps with the learning rate
    (``config.learning_rate`` unless given) decaying linearly to zero; returns the last epoch's mean
    loss. Each epoch's samples: :func:`epoch_samples` with ``config.perturbed_share``. A codebook
    student (``student.codebook``) fits its action logits to the label's row by cross-entropy."""
    import torch

    policy = student.model.policy
    rng = np.random.default_rng(seed)
    if student.codebook is not None:
        drive_classes = student.codebook_index(drives.reshape(-1, 5)).reshape(len(drives), 2)

    def epoch():
        x, y = epoch_samples(obs, drives, rng, config.perturbed_share)
        x = torch.as_tensor(student.venv.normalize_obs(x.astype(np.float64)), dtype=torch.float32)
        if student.codebook is not None:  # the label is one of each sample's two drive actions: its class
            labels = torch.as_tensor(np.where(np.all(y == drives[:, 1], axis=1), drive_classes[:, 1],
                                              drive_classes[:, 0]))
            logits = policy_raw_logits if config.raw_logits else policy_logits
            return len(x), lambda idx: torch.nn.functional.cross_entropy(logits(policy, x[idx]), labels[idx])
        y = torch.as_tensor(y, dtype=torch.float32)
        return len(x), lambda idx: edge_loss(policy_mean(policy, x[idx]), y[idx], config.huber_delta)

    policy.set_training_mode(True)
    loss = adam_fit([*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()], epoch, steps,
                    config.batch, learning_rate or config.learning_rate, seed, "distill: fit", progress,
                    bf16_share=config.bf16_share, fused=config.fused_adam, flush_denormal=config.flush_denormal)
    policy.set_training_mode(False)
    return loss


def distill(field_: DriveField, config: DistillConfig, seed: int = 0, env_kwargs: dict | None = None,
            hyperparameters: dict | None = None, validation_points=None, progress: bool = True,
            friction=None, on_round=None, checkpoint: str | Path | None = None) -> Student:
    """Fit a new PPO student to the drive field's teacher (module docstring), then ``config.rounds``
    DAgger rounds; prints each stage and, with ``validation_points``, the student's velocity as a
    fraction of the teacher's there. With ``friction`` ((mu low, high), (mu1 low, high)) the episodes'
    friction is drawn too (``draw_points``), ``field_`` is queried at (k, load, mu, mu1) points (a
    ``FrictionField``) and ``env_kwargs`` must give the privileged observation. ``on_round(student,
    record)``, if given, is called after each round and hole round with that round's history record
    (e.g. to save the student as it stands). With ``checkpoint`` (a file path), round 0's result is
    written there, and read from there instead of fitted if it was written for the same teacher and
    settings (``mdr_drive_agents.student.checkpoint``): an interrupted run continues after round 0;
    round 0's labelled episodes are written there before its fit, so a run interrupted during that
    fit continues at the fit."""
    import torch

    check_drawn_friction(config, friction is not None)  # before any work, not after round 0's fit
    for _, band in config.focus_bands():
        clipped_k_range(field_, band)  # a band outside the teacher's k: an error before any work
    torch.set_num_threads(config.torch_threads)
    rng = np.random.default_rng(seed)
    codebook = {}
    if config.action_codebook:  # the table in the env's action units, as labelled_episodes shifts the labels
        origin = float((env_kwargs or {}).get("z_phase_origin", 0.0))
        codebook = {"action_codebook": shift_phase_origin(grid_actions(field_), 0.0, origin)}
    student = make_student(config.net_arch, config.activation, config.log_std, seed, {**(env_kwargs or {}), **codebook},
                           hyperparameters or {})
    val = None
    if validation_points:
        val = (validation_points, teacher_drives(field_, validation_points, config)[1])
    obs_all, drive_all, restored = [], [], None
    if checkpoint is not None:
        fitted_for = round0_checkpoint.fingerprint(field_, config, seed, env_kwargs or {}, hyperparameters or {}, friction)
        restored, why_not = round0_checkpoint.load(checkpoint, fitted_for)
        if why_not:
            print(f"distill: {why_not}: round 0 is fitted again", file=sys.stderr, flush=True)
    for r in range(config.rounds + 1):
        if r == 0 and restored is not None and round0_checkpoint.is_fitted(restored):
            obs_all, drive_all, record = round0_checkpoint.restore(restored, student, rng)
            student.history.append(record)
            print(f"distill: round 0 read from {checkpoint}", flush=True)
            _print_record(record)
            continue
        t0 = time.perf_counter()
        if r == 0 and restored is not None:  # labelled, not fitted: the fit goes on from its episodes
            obs_all, drive_all, labelled = round0_checkpoint.restore(restored, student, rng)
            n_jump, t0 = labelled["jump_points"], t0 - labelled["labelling_s"]
            print(f"distill: round 0's episodes read from {checkpoint}", flush=True)
        else:
            points, drives, n_jump = round_points(field_, config, rng, friction, first=r == 0)
            obs, sample_drives = labelled_episodes(field_, points, None if r == 0 else student.act, config, seed + r,
                                                   student.z_phase_origin, student.time_quantum, drives=drives)
            obs_all.append(obs)
            drive_all.append(sample_drives)
        if r == 0 and restored is None:  # normalisation statistics of the teacher's observations, fixed from here on
            obs64 = obs.astype(np.float64)
            student.venv.obs_rms.mean, student.venv.obs_rms.var = obs64.mean(axis=0), obs64.var(axis=0)
            student.venv.obs_rms.count = float(len(obs))
            if checkpoint is not None:
                round0_checkpoint.save(checkpoint, student, rng, obs_all, drive_all,
                                       {"jump_points": n_jump, "labelling_s": round(time.perf_counter() - t0, 1)},
                                       fitted_for, fitted=False)
        loss = fit(student, np.concatenate(obs_all), np.concatenate(drive_all),
                   config.steps if r == 0 else config.round_steps, config, seed + r, progress)
        record = {"round": r, **({"jump_points": n_jump} if r == 0 and config.jump_levels else {}),
                  "samples": int(sum(len(o) for o in obs_all)), "loss": loss,
                  "wall_time_s": round(time.perf_counter() - t0, 1)}
        if val is not None:
            record.update(validation_fraction(student, *val))
        student.history.append(record)
        _print_record(record)
        if r == 0 and checkpoint is not None:
            round0_checkpoint.save(checkpoint, student, rng, obs_all, drive_all, record, fitted_for)
        if on_round is not None:
            on_round(student, record)
    for h in range(1, config.hole_rounds + 1):
        record = hole_round(student, field_, config, h, rng, seed, obs_all, drive_all, friction, progress)
        if val is not None:
            record.update(validation_fraction(student, *val))
        student.history.append(record)
        _print_record(record)
        if on_round is not None:
            on_round(student, record)
    return student


def round_points(field_: DriveField, config: DistillConfig, rng: np.random.Generator, friction=None,
                 first: bool = True) -> tuple[list, np.ndarray, int]:
    """A round's points and the teacher's drive at each (n, 2, 5): ``config.points`` random points
    (``draw_points`` with ``friction``), and in the first round (round 0) the focus bands' and, with
    ``config.jump_levels``, the jump bisection's (``jump_points``) after them; returns them and the
    number of jump points."""
    points = draw_points(field_, config.points, rng, config, friction)
    for n, band in config.focus_bands() if first else ():
        points += draw_points(field_, n, rng, config, friction, k_range=band)
    drives, _ = teacher_drives(field_, points, config)
    extra = []
    if first and config.jump_levels:
        extra, extra_drives = jump_points(field_, points, drives, config)
        points, drives = points + extra, np.concatenate([drives, extra_drives]) if extra else drives
    return points, drives, len(extra)


def hole_round(student: Student, field_: DriveField, config: DistillConfig, h: int, rng: np.random.Generator,
               seed: int, obs_all: list, drive_all: list, friction=None, progress: bool = True) -> dict:
    """Hole round ``h`` (module docstring): :func:`find_holes`, the teacher's episodes at and around
    the holes (and with ``config.hole_dagger`` the student's, labelled by the teacher) appended to
    ``obs_all`` and ``drive_all``, and the fit continued on all of them; returns the round's record."""
    t0 = time.perf_counter()
    holes, probe = find_holes(student, field_, config, rng, friction)
    loss = None  # no hole found: no fit this round
    if holes:
        k_range = (float(field_.ks[0]), float(field_.ks[-1]))
        points = around(holes, config.hole_neighbours, rng, k_range)
        drives, _ = teacher_drives(field_, points, config)
        for act in (None, student.act) if config.hole_dagger else (None,):
            obs, sample_drives = labelled_episodes(field_, points, act, config, seed + 100 + h, student.z_phase_origin,
                                                   student.time_quantum, drives=drives)
            obs_all.append(obs)
            drive_all.append(sample_drives)
        loss = fit(student, np.concatenate(obs_all), np.concatenate(drive_all), config.hole_steps, config,
                   seed + 100 + h, progress, learning_rate=config.hole_learning_rate)
    return {"hole_round": h, **probe, "samples": int(sum(len(o) for o in obs_all)),
            "loss": loss, "wall_time_s": round(time.perf_counter() - t0, 1)}


def _print_record(record: dict) -> None:
    print(" ".join(f"{key}={value:.4g}" if isinstance(value, float) else f"{key}={value}"
                   for key, value in record.items()), flush=True)


def student_velocity(student: Student, points) -> np.ndarray:
    """The student's steady velocity (m/s) at each (k, load kg) or (k, load kg, mu, mu1) point, closed
    loop over 30 periods."""
    _, _, disp = rollout(points, np.zeros((len(points), 2, 5)), student.act, 30, z_phase_origin=student.z_phase_origin,
                         time_quantum=student.time_quantum, drive=student.drive)
    return steady_velocity_of(disp, period=student.drive.period)


def check_drawn_friction(config: DistillConfig, friction_drawn: bool) -> None:
    """The options that need the drive field's one friction, refused (a ``ValueError`` naming the
    option) where the episodes' friction is drawn: stall probes (placed at the field's stall)."""
    if config.stall_probes and friction_drawn:
        raise ValueError("stall_probes: not with a drawn friction (the field's stall is at one friction)")


def find_holes(student: Student, field_: DriveField, config: DistillConfig, rng: np.random.Generator,
               friction=None):
    """The student and the teacher at ``config.hole_probes`` fresh random points (``draw_points``
    with ``friction``) and ``config.stall_probes`` points around the teacher's stall
    (``stall_points``): the points where the student's steady velocity falls short of the teacher's
    (``config.hole_shortfall``; at the stall probes, also where the student stalls and the teacher
    moves), and the probe statistics (share of holes, the student's mean velocity over the
    teacher's where it moves)."""
    check_drawn_friction(config, friction is not None)
    points = draw_points(field_, config.hole_probes, rng, config, friction)
    if config.stall_probes:
        points += stall_points(field_, config.stall_probes, rng, config.stall_band)
    _, v_teacher = teacher_drives(field_, points, config)
    v_student = student_velocity(student, points)
    short = v_student < v_teacher - np.maximum(config.hole_shortfall * np.abs(v_teacher), config.hole_floor)
    stalled = (v_teacher > 0.0) & ~(v_student > 0.0)
    stalled[:config.hole_probes] = False
    short |= stalled
    moving = v_teacher >= 2e-3
    return [p for p, h in zip(points, short) if h], {
        "probes": len(points), "holes": int(short.sum()),
        **({"stall_holes": int(short[config.hole_probes:].sum())} if config.stall_probes else {}),
        "probe_mean_fraction": float(np.mean(v_student[moving] / v_teacher[moving])) if moving.any() else None}


def validation_fraction(student: Student, points, v_teacher: np.ndarray, moving: float = 2e-3) -> dict:
    """The student's steady velocity over the teacher's where the teacher moves >= ``moving`` m/s."""
    v = student_velocity(student, points)
    keep = v_teacher >= moving
    frac = v[keep] / v_teacher[keep]
    return {"val_mean_fraction": float(frac.mean()), "val_min_fraction": float(frac.min()),
            "val_below_teacher": int((v < v_teacher - 0.05e-3).sum())}


__all__ = ["FOCUS_KEYS", "DistillConfig", "check_drawn_friction", "distill", "epoch_samples", "find_holes", "fit",
           "hole_round", "round_points", "student_velocity", "validation_fraction"]
