"""mdr-drive bench's parts that run in seconds: the vector env's rates by thread count and the report."""

import json

from mdr_drive_env import bench
from mdr_drive_env.core import batch
from tests import ROOT


def test_vector_rates_measure_every_thread_count():
    limit = batch.MIN_DRIVES_PER_THREAD
    rates = bench.vector_rates(8, 3, 2, [1, 2])
    assert set(rates) == {1, 2} and all(r > 0 for r in rates.values())
    assert batch.MIN_DRIVES_PER_THREAD == limit


def test_markdown_reports_the_scaling_curve_with_its_ratio():
    res = json.loads((ROOT / "results" / "bench" / "bench_speed.json").read_text())
    res["vector_env_scaling"] = {"8": {"1": 100.0, "2": 150.0}, "64": {"1": 200.0, "2": 380.0}}
    res["min_drives_per_thread"] = 8
    text = bench.markdown(res)
    assert "| N | 1 thread | 2 threads | 2 over 1 |" in text
    assert "| 8 | 100 | 150 | 1.50 |" in text and "| 64 | 200 | 380 | 1.90 |" in text
    assert "below the default's 8 drives a thread too" in text

