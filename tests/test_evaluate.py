"""The Monte Carlo campaign: paired runs, per-run metrics, resume, summary."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from uwb_env.agents.campaign import ONE_RECEIVER, Campaign, make_env, play_scheme, run_campaign, run_path
from uwb_env.agents.cli import evaluate_main as main
from uwb_env.agents.cli import parse_overrides
from uwb_env.agents.summary import mean_ci, run_metrics, summarise

SMALL = {"n_scans": 12, "targets.1.birth_time_s": 1.0}


def _campaign(runs: int) -> Campaign:
    return Campaign(
        env="uwb_env/UrbanWaveform-v3",
        schemes=("myopic", "round-robin@open-loop"),
        baseline="round-robin@open-loop",
        runs=runs,
        seed0=7,
        overrides=SMALL,
    )


def test_run_metrics_by_hand():
    rec = {
        "true_confirmed": np.array([0.0, 1.0, 2.0]),
        "sq_error_sum": np.array([0.0, 0.25, 0.5]),  # 3 matched errors, squared sum 0.75 -> RMSE 0.5
        "ospa_m": np.array([10.0, 1.0, 1.0]),
        "confirmed": np.array([0.0, 2.0, 2.0]),
        "false": np.array([0.0, 1.0, 0.0]),
        "trace_m2": np.array([np.nan, 3.0, 1.0]),
        "target_trace_m2": np.array([np.nan, 2.0, 1.0]),
        "energy_j": np.array([1e-3, 1e-3, 2e-3]),
        "reward": np.array([-100.0, -3.0, -1.0]),
        "alive": np.array([2.0, 2.0, 2.0]),
        "missed": np.array([2.0, 1.0, 0.0]),
        "missed_penalty": np.array([200.0, 100.0, 0.0]),  # 100 m^2 per missed target
    }
    m = run_metrics(rec)
    # per scan (covered traces + penalties) / alive: (0 + 200) / 2, (2 + 100) / 2, (2 x 1 + 0) / 2
    assert m["target_cost_m2"] == pytest.approx((100.0 + 51.0 + 1.0) / 3)
    assert m["rmse_m"] == pytest.approx(0.5)
    assert m["ospa_m"] == pytest.approx(4.0)
    assert m["confirmed"] == pytest.approx(4 / 3) and m["true_confirmed"] == pytest.approx(1.0)
    assert m["false"] == pytest.approx(1 / 3)
    assert m["trace_m2"] == pytest.approx(2.0) and m["target_trace_m2"] == pytest.approx(1.5)
    assert m["energy_j"] == pytest.approx(4e-3) and m["return"] == pytest.approx(-104.0)


def test_mean_ci_is_the_t_interval():
    mean, half, n = mean_ci(np.array([1.0, 2.0, 3.0, np.nan]))
    assert (mean, n) == (2.0, 3)
    assert half == pytest.approx(4.302652729911275 * 1.0 / math.sqrt(3))  # t_0.975(2) s / sqrt(n), s = 1


def test_resumed_campaign_gives_the_same_summary(tmp_path):
    """Uninterrupted (one process) vs interrupted (2 runs over two processes, a run file lost, then 3 runs)."""
    whole, parts = tmp_path / "whole", tmp_path / "parts"
    run_campaign(_campaign(3), whole, workers=1, progress=False)
    reference = summarise(_campaign(3), whole)

    run_campaign(_campaign(2), parts, workers=2, progress=False)
    lost = run_path(parts, "myopic", 8)
    lost.unlink()  # as if the campaign was killed while this run was playing
    kept = run_path(parts, "round-robin@open-loop", 7)
    stamp = kept.stat().st_mtime_ns
    run_campaign(_campaign(3), parts, workers=1, progress=False)
    assert kept.stat().st_mtime_ns == stamp  # finished runs are not recomputed
    assert summarise(_campaign(3), parts) == reference
    assert (parts / "runs.csv").read_text() == (whole / "runs.csv").read_text()
    for name in ("confirmed_tracks.png", "position_rmse.png", "model_probabilities.png"):
        assert (parts / name).stat().st_size > 10_000

    # common random numbers: the truth is the same for every scheme of a seed
    a = np.loadtxt(run_path(whole, "myopic", 9), delimiter=",", skiprows=1)
    b = np.loadtxt(run_path(whole, "round-robin@open-loop", 9), delimiter=",", skiprows=1)
    np.testing.assert_array_equal(a[:, 1], b[:, 1])  # alive targets per scan
    assert a.shape == (12, 14 + 4) and b.shape == (12, 14 + 1)  # VS-IMM's 4 models, the open loop's one


def test_a_changed_definition_does_not_resume(tmp_path):
    run_campaign(_campaign(2), tmp_path, workers=1, progress=False)
    other = Campaign(**{**_campaign(2).__dict__, "overrides": {**SMALL, "n_scans": 13}})
    with pytest.raises(ValueError, match="field 'overrides'"):
        run_campaign(other, tmp_path, workers=1, progress=False)
    assert json.loads((tmp_path / "campaign.json").read_text())["overrides"] == SMALL


def test_bad_campaigns_raise(capsys):
    with pytest.raises(ValueError, match="env='x'"):
        Campaign(env="x", schemes=("myopic",), baseline="myopic", runs=3)
    with pytest.raises(ValueError, match="runs=1"):
        Campaign(env="uwb_env/UrbanWaveform-v3", schemes=("myopic",), baseline="myopic", runs=1)
    with pytest.raises(ValueError, match="tracker 'nn'"):
        Campaign(env="uwb_env/UrbanWaveform-v3", schemes=("myopic@nn",), baseline="myopic@nn", runs=3)
    with pytest.raises(ValueError, match="scheduler='greedy'"):
        Campaign(env="uwb_env/UrbanWaveform-v3", schemes=("greedy",), baseline="greedy", runs=3)
    with pytest.raises(ValueError, match="baseline='random'"):
        Campaign(env="uwb_env/UrbanWaveform-v3", schemes=("myopic",), baseline="random", runs=3)
    with pytest.raises(SystemExit) as e:
        main(["--set", "n_scans", "--runs", "2"])
    assert e.value.code == 2 and "--set 'n_scans'" in capsys.readouterr().err


def test_the_open_loop_on_one_receiver_is_the_open_loop_tracker_with_the_overrides_of_one_pair():
    """Seed 003's baseline "without any diversity mode": one NCV UKF on pair (0, 0), that receiver's azimuth added;
    the same run as the open-loop scheme on a campaign that sets those overrides itself (and they are not set twice).
    """
    one = Campaign(**{**_campaign(2).__dict__, "schemes": ("round-robin@open-loop-one-rx",),
                      "baseline": "round-robin@open-loop-one-rx"})  # fmt: skip
    env = make_env(one, "open-loop-one-rx")
    assert env.sim.sensor.pairs.tolist() == [[0, 0]] and env.cfg.sensing.measure_doa
    assert env.sim.tracker.model_names == ("ncv",)
    assert make_env(_campaign(2), "open-loop").sim.sensor.pairs.tolist() == [[0, 0], [0, 1]]  # the scenario's two
    direct = Campaign(**{**_campaign(2).__dict__, "overrides": {**SMALL, **ONE_RECEIVER}})
    a, names = play_scheme(one, "round-robin@open-loop-one-rx", 8)
    b, names_b = play_scheme(direct, "round-robin@open-loop", 8)
    assert names == names_b
    np.testing.assert_array_equal(a, b)
    clash = Campaign(**{**one.__dict__, "overrides": {**SMALL, "sensing.measure_doa": False}})
    with pytest.raises(ValueError, match=r"'open-loop-one-rx' sets \['sensing.measure_doa'\] itself"):
        make_env(clash, "open-loop-one-rx")


def test_an_open_loop_takes_its_ncv_white_acceleration_and_bad_ones_are_refused():
    tuned = Campaign(
        **{**_campaign(2).__dict__, "schemes": ("myopic", "round-robin@open-loop:1.57"), "baseline": "myopic"}
    )
    for tracker, sigma in (("open-loop:1.57", 1.57), ("open-loop", 0.5), ("open-loop-one-rx:2", 2.0)):
        (model,) = make_env(tuned, tracker).cfg.tracker.models
        assert (model.kind, model.accel_noise_std_mps2) == ("ncv", sigma)
    for scheme, why in (("myopic@open-loop:abc", "SIGMA 'abc' must be a number in (0, 1000]"),
                        ("myopic@open-loop:0", "SIGMA '0' must be"), ("myopic@open-loop:nan", "SIGMA 'nan' must be"),
                        ("myopic@imm-lmipda:1", "only an open-loop tracker takes ':SIGMA'")):  # fmt: skip
        with pytest.raises(ValueError, match=re.escape(why)):
            Campaign(env="uwb_env/UrbanWaveform-v3", schemes=(scheme,), baseline=scheme, runs=3)


def test_command_line_prints_the_table(tmp_path, capsys):
    args = ["--schemes", "fixed-0", "fixed-3", "--runs", "2", "--set", "n_scans=8", "--set", "targets.1.birth_time_s=1"]
    main([*args, "--out", str(tmp_path), "--workers", "1", "--no-progress"])
    out = capsys.readouterr().out
    assert "| fixed-0 | position RMSE [m] |" in out and "Paired differences against `fixed-3`" in out
    assert (tmp_path / "summary.md").read_text() in out


def test_command_line_values_parse_as_yaml_and_floats():
    got = parse_overrides(["a=1e-5", "b=true", "c.d=3", "e=parametric", "f=1.5e2", "g=[1, 2]"])
    assert got == {"a": 1e-5, "b": True, "c.d": 3, "e": "parametric", "f": 150.0, "g": [1, 2]}
    assert isinstance(got["a"], float) and isinstance(got["c.d"], int)
    with pytest.raises(ValueError, match="--env-kwarg 'nokey'"):
        parse_overrides(["nokey"], "--env-kwarg")


def test_sign_rank_counts_and_p_value():
    """Counts of positive / negative paired differences and Wilcoxon's exact two-sided p (zeros dropped).

    Ten positive differences, distinct ranks: the exact null probability of rank sum 55 (the maximum) is 2^-10,
    two-sided 2 * 2^-10 = 0.00195.
    """
    from uwb_env.agents.summary import sign_rank

    d = np.array([0.0, 0.0, *np.arange(1.0, 11.0)])
    assert sign_rank(d) == (10, 0, "0.002")
    assert sign_rank(np.array([1.0, -2.0, 0.0, np.nan])) == (1, 1, "-")


# ------------------------------------------------------------------------- across training seeds (issue 20, item 4)
SEED_SCHEMES = [f"rl:runs/x/seed-{s}" for s in range(5)]
ACROSS_RETURN = {"myopic": [3, 3, 3], 0: [1, 2, 3], 1: [4, 4, 4], 2: [0, 0, 3], 3: [10, 20, 30], 4: [3, 3, 3]}
ACROSS_RMSE = {"myopic": [2, 1, 2], 0: [1, 9, 3], 1: [2, 9, 2], 2: [0.5, math.nan, 0.5], 3: [4, 9, 4], 4: [1, 9, 5]}


def _write_runs_csv(path):
    """A runs.csv of myopic and five seeds of rl:runs/x on episodes 0..2 (other metrics constant 1)."""
    from uwb_env.agents.campaign import METRICS

    lines = ["scheme,seed," + ",".join(METRICS)]
    for key in ["myopic", *range(5)]:
        scheme = key if key == "myopic" else SEED_SCHEMES[key]
        for ep in range(3):
            row = {m: 1.0 for m in METRICS} | {"return": ACROSS_RETURN[key][ep], "rmse_m": ACROSS_RMSE[key][ep]}
            lines.append(f"{scheme},{ep}," + ",".join(str(row[m]) for m in METRICS))
    path.write_text("\n".join(lines) + "\n")


def test_across_seeds_per_seed_means_iqm_and_improvement_by_hand(tmp_path):
    """Per-seed return means 2, 4, 1, 20, 3: IQM = mean of the middle three (2, 3, 4) = 3; myopic 3: P(improvement)
    = (0 + 1 + 0 + 1 + 1/2) / 5 = 0.5. RMSE (lower is better) on the episodes finite for all (0 and 2): per seed
    2, 2, 0.5, 4, 3 -> IQM (2 + 2 + 3) / 3, myopic 2, P = (1/2 + 1/2 + 1 + 0 + 0) / 5 = 0.4."""
    from uwb_env.agents.summary import across_seeds, read_runs_csv

    _write_runs_csv(tmp_path / "runs.csv")
    schemes, metrics = read_runs_csv(tmp_path / "runs.csv")
    assert schemes == ["myopic", *SEED_SCHEMES]
    rows = across_seeds(schemes, "myopic", metrics)["rl:runs/x"]
    ret, rmse = rows["return"], rows["rmse_m"]
    assert ret.seeds == (0, 1, 2, 3, 4) and ret.episodes == 3
    np.testing.assert_allclose(ret.per_seed, [2, 4, 1, 20, 3])
    assert ret.iqm.point == pytest.approx(3.0) and ret.baseline == pytest.approx(3.0)
    assert ret.improvement.point == pytest.approx(0.5)
    assert rmse.episodes == 2
    np.testing.assert_allclose(rmse.per_seed, [2, 2, 0.5, 4, 3])
    assert rmse.iqm.point == pytest.approx(7 / 3) and rmse.baseline == pytest.approx(2.0)
    assert rmse.improvement.point == pytest.approx(0.4)
    # a constant metric: every seed ties with myopic, the interval collapses
    energy = rows["energy_j"]
    assert (energy.iqm.low, energy.iqm.high, energy.improvement.point) == (1.0, 1.0, 0.5)


def test_across_seeds_interval_is_the_exact_bootstrap_percentile():
    """The bootstrap over 5 seeds has 5^5 = 3,125 equally likely resamples: enumerate them for the exact
    distribution of the IQM. With 10,000 replicates the 2.5 % percentile's empirical CDF has SE
    sqrt(0.025 x 0.975 / 10^4) = 0.0016: the interval's ends lie between the exact 1.5 / 3.5 % and 96.5 / 98.5 %
    quantiles (6 SE)."""
    import itertools

    from scipy import stats

    from uwb_env.agents.campaign import METRICS
    from uwb_env.agents.summary import across_seeds

    metrics = {s: {m: np.ones(3) for m in METRICS} for s in ["myopic", *SEED_SCHEMES]}
    per_seed = np.array([2.0, 4.0, 1.0, 20.0, 3.0])
    for i, s in enumerate(SEED_SCHEMES):
        metrics[s]["return"] = np.full(3, per_seed[i])
    est = across_seeds(["myopic", *SEED_SCHEMES], "myopic", metrics)["rl:runs/x"]["return"].iqm
    resamples = per_seed[np.array(list(itertools.product(range(5), repeat=5)))]  # (3125, 5)
    exact = stats.trim_mean(resamples, 0.25, axis=1)
    lo = np.quantile(exact, [0.015, 0.035], method="inverted_cdf")
    hi = np.quantile(exact, [0.965, 0.985], method="inverted_cdf")
    assert lo[0] <= est.low <= lo[1] and hi[0] <= est.high <= hi[1]
    assert est.confidence == 0.95 and est.reps == 10_000


def test_across_seeds_section_in_the_summary_text(tmp_path):
    from uwb_env.agents.campaign import METRICS
    from uwb_env.agents.summary import HIGHER_IS_BETTER, across_seeds_lines, read_runs_csv

    assert set(HIGHER_IS_BETTER) == set(METRICS)  # a new metric needs its direction
    _write_runs_csv(tmp_path / "runs.csv")
    schemes, metrics = read_runs_csv(tmp_path / "runs.csv")
    text = "\n".join(across_seeds_lines(schemes, "myopic", metrics))
    assert "## Across training seeds: `rl:runs/x` (seeds 0..4)" in text
    assert "| return | higher | 2 | 4 | 1 | 20 | 3 | 3 [" in text and "| 3 | +0.0 % | 0.50 [" in text
    assert "| position RMSE [m] | lower | 2 | 2 | 0.5 | 4 | 3 | 2.333 [" in text and "| 0.40 [" in text
    assert across_seeds_lines(["myopic", "rl:runs/y"], "myopic", metrics) == []  # no multi-seed group


def test_read_runs_csv_refuses_unpaired_or_incomplete_files(tmp_path):
    from uwb_env.agents.summary import read_runs_csv

    _write_runs_csv(tmp_path / "runs.csv")
    lines = (tmp_path / "runs.csv").read_text().splitlines()
    (tmp_path / "short.csv").write_text("\n".join(lines[:-1]) + "\n")  # seed 4's last episode missing
    with pytest.raises(ValueError, match=r"short\.csv.*not played on the same seeds"):
        read_runs_csv(tmp_path / "short.csv")
    (tmp_path / "cols.csv").write_text("scheme,seed,return\nmyopic,0,1\n")
    with pytest.raises(ValueError, match=r"cols\.csv.*columns \['rmse_m'"):
        read_runs_csv(tmp_path / "cols.csv")
