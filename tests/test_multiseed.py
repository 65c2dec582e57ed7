"""Multi-seed runs (issue 20, item 4): the seed-<s>/ layout, campaign schemes per seed, learning curves across seeds.

Torch-free: the runs are folders with the files the code reads (``run.yaml``, ``eval.csv``), written here.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import stats

from uwb_env.agents import multiseed
from uwb_env.agents.cli import campaign_from_args, evaluate_parser

EVAL_HEADER = "timesteps,return,trace_m2,myopic_return,myopic_trace_m2,round_robin_return,round_robin_trace_m2"
RETURNS = {0: [-50, -20, -10], 1: [-40, -30, -12], 2: [-60, -25, -9], 3: [-45, -90, -11], 4: [-55, -21, -10, -8]}
TRACES = {0: [4, 2, 1], 1: [5, 3, 1], 2: [math.nan, 2.5, 1], 3: [4, 2, 1], 4: [6, 3, 1, 0.5]}


def _runs(root, seeds=range(5), eval_logs=True):
    """A multi-seed folder: seed-<s>/run.yaml (+ eval.csv at steps 100, 200, 300; seed 4 also at 400)."""
    for s in seeds:
        d = root / f"seed-{s}"
        d.mkdir(parents=True)
        (d / "run.yaml").write_text(f"seed: {s}\n")
        if eval_logs:
            pairs = zip(RETURNS[s], TRACES[s], strict=True)
            rows = [EVAL_HEADER] + [f"{100 * (k + 1)},{r},{t},-5.0,0.7,-9.0,2.0" for k, (r, t) in enumerate(pairs)]
            (d / "eval.csv").write_text("\n".join(rows) + "\n")
    return root


def test_seed_runs_and_scheme_expansion(tmp_path):
    x = _runs(tmp_path / "x", seeds=[0, 2, 10], eval_logs=False)
    (x / "seed-3").mkdir()  # no run.yaml: not a run
    (x / "notes").mkdir()
    assert [s for s, _ in multiseed.seed_runs(x)] == [0, 2, 10]
    assert multiseed.is_multi_seed(x) and not multiseed.is_multi_seed(x / "seed-0")
    got = multiseed.expand_seed_schemes(["myopic", f"rl:{x}@imm-lmipda", f"rl:{x / 'seed-0'}", "rl:nowhere"])
    assert got[:4] == ["myopic", f"rl:{x}/seed-0@imm-lmipda", f"rl:{x}/seed-2@imm-lmipda", f"rl:{x}/seed-10@imm-lmipda"]
    assert got[4:] == [f"rl:{x}/seed-0", "rl:nowhere"]  # a single run and a missing folder are kept as given
    assert multiseed.expand_seed_schemes([f"rllib:{x}"]) == [f"rllib:{x}/seed-{s}" for s in (0, 2, 10)]
    with pytest.raises(ValueError, match="listed twice"):
        multiseed.expand_seed_schemes([f"rl:{x}", f"rl:{x}/seed-2"])


def test_seed_groups_from_scheme_names():
    schemes = ["myopic", "rl:r/a/seed-1", "rl:r/a/seed-0", "rl:r/a/seed-0@pf", "rl:r/b/seed-4", "rl:r/c", "fixed-2"]
    assert multiseed.seed_of("rl:r/a/seed-0@pf") == ("rl:r/a@pf", 0)
    assert multiseed.seed_of("rl:r/c") is None and multiseed.seed_of("myopic") is None
    assert multiseed.seed_groups(schemes) == {"rl:r/a": [(0, "rl:r/a/seed-0"), (1, "rl:r/a/seed-1")]}
    assert set(multiseed.seed_groups(schemes, minimum=1)) == {"rl:r/a", "rl:r/a@pf", "rl:r/b"}


def test_the_campaign_command_expands_a_multi_seed_run_and_refuses_it_as_baseline(tmp_path):
    x = _runs(tmp_path / "x", seeds=[0, 1], eval_logs=False)
    for s in (0, 1):
        (x / f"seed-{s}" / "model.zip").write_bytes(b"")  # check_scheduler_name: a run is run.yaml + model.zip
    args = evaluate_parser().parse_args(["--schemes", "myopic", f"rl:{x}", "--baseline", "myopic"])
    camp = campaign_from_args(args)
    assert camp.schemes == ("myopic", f"rl:{x}/seed-0", f"rl:{x}/seed-1") and camp.baseline == "myopic"
    args = evaluate_parser().parse_args(["--schemes", "myopic", f"rl:{x}"])  # default baseline: the last scheme
    with pytest.raises(ValueError, match=r"a multi-seed run .* cannot be the baseline"):
        campaign_from_args(args)


def test_learning_curves_iqm_band_and_references(tmp_path):
    """Five seeds; steps 100..300 common (seed 4's 400 left out). Step 200's returns -20, -30, -25, -90, -21:
    IQM = mean of the middle three (-21, -25, -30) = -25.33. Traces at step 300 all 1: a zero-width band. Seed 2's
    trace at step 100 is nan: no IQM there."""
    lc = multiseed.learning_curves(_runs(tmp_path / "x"))
    ret, trace = lc.curves["return"], lc.curves["trace_m2"]
    assert lc.seeds == (0, 1, 2, 3, 4)
    np.testing.assert_array_equal(ret.timesteps, [100, 200, 300])
    np.testing.assert_array_equal(ret.per_seed[:, 1], [-20, -30, -25, -90, -21])
    np.testing.assert_allclose(ret.iqm, [-50.0, -76 / 3, -10.333333333333334])  # (-50-45-55)/3, ..., (-10-11-10)/3
    assert ret.references == {"myopic": -5.0, "round-robin": -9.0}
    assert trace.references == pytest.approx({"myopic": 0.7, "round-robin": 2.0})
    assert math.isnan(trace.iqm[0]) and math.isnan(trace.low[0]) and math.isnan(trace.high[0])
    assert (trace.iqm[2], trace.low[2], trace.high[2]) == (1.0, 1.0, 1.0)
    # step 200's band against the exact bootstrap (5^5 resamples); 2,000 replicates: 2.5 % +- 1.5 % (4 SE)
    values = ret.per_seed[:, 1]
    exact = stats.trim_mean(values[np.array(list(itertools.product(range(5), repeat=5)))], 0.25, axis=1)
    lo = np.quantile(exact, [0.01, 0.04], method="inverted_cdf")
    hi = np.quantile(exact, [0.96, 0.99], method="inverted_cdf")
    assert lo[0] <= ret.low[1] <= lo[1] and hi[0] <= ret.high[1] <= hi[1]
    again = multiseed.learning_curves(tmp_path / "x")  # seeded: the same band
    np.testing.assert_array_equal(again.curves["return"].low, ret.low)


def test_learning_curves_png_and_the_script(tmp_path, capsys):
    x = _runs(tmp_path / "x")
    path = multiseed.plot_learning_curves(x)
    assert path == x / "learning_curves.png" and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    multiseed.curves_main([str(x), "--out", str(tmp_path / "c.png")])
    out = capsys.readouterr().out
    assert "return at 300 steps: IQM -10.33 [" in out and "myopic -5, round-robin -9" in out
    assert (tmp_path / "c.png").is_file()


def test_learning_curves_refuse_folders_without_logs(tmp_path):
    with pytest.raises(ValueError, match=r"no seed-<s>/eval\.csv"):
        multiseed.learning_curves(_runs(tmp_path / "x", eval_logs=False))
    y = _runs(tmp_path / "y", seeds=[0])
    (y / "seed-0" / "eval.csv").write_text("timesteps,return\n100,-3\n")
    with pytest.raises(ValueError, match=r"eval\.csv: cannot be read .* columns \['trace_m2'"):
        multiseed.learning_curves(y)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--seeds", "0"], "argument --seeds: 0 must be >= 1"),
        (["--engine", "rllib", "--seeds", "2"], "--seeds: only with --engine sb3"),
    ],
)
def test_train_command_checks_seeds(tmp_path, capsys, argv, message):
    from uwb_env.agents.cli import train_main

    with pytest.raises(SystemExit) as e:
        train_main([*argv, "--out", str(tmp_path / "r")])
    assert e.value.code == 2 and message in capsys.readouterr().err
