"""A blind benchmark as a reference: any policy scored against it with the standard score."""

import numpy as np
import pytest

from mdr_drive_agents.benchmarks.reference import Reference
from mdr_drive_agents.benchmarks.score import normalized_scores
from mdr_drive_agents.protocol import trapezoid_action
from tests import ROOT

TINY = ROOT / "tests" / "data" / "blind_tiny_b.json"


class Trapezoid:
    """The paper's waveform every period, as a closed-loop drive at the reference's time quantum."""

    play_kwargs = {"time_quantum": 5e-6}

    def act(self, obs):
        return np.repeat(trapezoid_action()[None], len(obs), axis=0)


def test_a_reference_scores_as_the_standard_score(tmp_path):
    ref = Reference.load(TINY)
    v = ref.best * 0.5 + ref.trapezoid * 0.5
    np.testing.assert_allclose(ref.scores(v), normalized_scores(ref.trapezoid, ref.best, v))
    assert ref.name == "seed 20261256" and ref.time_quantum == 5e-6 and len(ref.points) == 6
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(ValueError, match="bad.json is not a blind benchmark's blind.json"):
        Reference.load(tmp_path / "bad.json")


def test_the_trapezoid_played_closed_loop_scores_zero_and_another_quantum_is_refused():
    ref = Reference.load(TINY)
    found = ref.score_policy(Trapezoid())
    np.testing.assert_allclose(found["velocity"], ref.trapezoid, atol=1e-9)
    scored = np.isfinite(found["scores"])
    assert scored.sum() == found["score"]["scores"] > 0
    np.testing.assert_allclose(found["scores"][scored], 0.0, atol=1e-6)

    class Coarse(Trapezoid):
        play_kwargs = {"time_quantum": 1e-5}

    with pytest.raises(ValueError, match="time quantum of 1e-05 s, this reference's search at 5e-06 s"):
        ref.score_policy(Coarse())
