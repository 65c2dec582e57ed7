"""The tracker seam (uwb_env.tracking.protocol): who reads what of a tracker, the registry, every kind in the loop."""

from __future__ import annotations

import ast
import importlib.util
import pathlib

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import uwb_env
from uwb_env import scenarios
from uwb_env.agents import make_scheduler
from uwb_env.config import TRACKER_KINDS, TrackerConfig, apply_overrides
from uwb_env.scene.layout import SceneLayout
from uwb_env.tracking.protocol import MultiTargetTracker
from uwb_env.tracking.registry import FACTORIES, make_tracker

ROOT = pathlib.Path(uwb_env.__file__).parent
PROTOCOL = {"kind", "cfg", "model_names", "filter", "tracks", "reset", "step", "scored_prediction",
            "predict_gaussians", "expected_update"}  # fmt: skip
TRACKSET = {"ids", "confirmed", "age", "born", "existence", "mu", "active", "x", "P", "combined", "select"}
AVAILABLE = [k for k in TRACKER_KINDS if importlib.util.find_spec(FACTORIES[k].partition(":")[0]) is not None]


def _is_tracker(node: ast.expr) -> bool:
    """``tracker`` or ``<...>.tracker``, but not the configuration's ``cfg.tracker`` (a TrackerConfig)."""
    if isinstance(node, ast.Name):
        return node.id == "tracker"
    if isinstance(node, ast.Attribute) and node.attr == "tracker":
        owner = node.value
        return not ((isinstance(owner, ast.Name) and owner.id == "cfg") or
                    (isinstance(owner, ast.Attribute) and owner.attr == "cfg"))  # fmt: skip
    return False


def _tracker_reads(path: pathlib.Path) -> tuple[set[str], set[str]]:
    """Attributes read of ``<...>.tracker.<a>`` / ``tracker.<a>`` and of ``<...>.tracker.tracks.<b>`` in a module."""
    direct, of_tracks = set(), set()
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.Attribute):
            continue
        if _is_tracker(node.value):
            direct.add(node.attr)
        elif isinstance(node.value, ast.Attribute) and node.value.attr == "tracks" and _is_tracker(node.value.value):
            of_tracks.add(node.attr)
    return direct, of_tracks


def _imports(path: pathlib.Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
            out.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


@pytest.mark.parametrize(
    "module", ["lookahead.py", "sim.py", "envs/scheduling.py", "../agents/campaign.py", "../agents/schedulers.py"]
)
def test_consumers_use_the_protocol_only(module):
    """The lookahead, simulator, env and campaigns read a tracker through the protocol (and its TrackSet) only."""
    path = (ROOT / module).resolve()
    if not path.exists():
        pytest.skip(f"{module} not in this layout")
    direct, of_tracks = _tracker_reads(path)
    assert direct - PROTOCOL - {"cfg"} == set(), f"{module} reads tracker internals {sorted(direct - PROTOCOL)}"
    assert of_tracks <= TRACKSET, f"{module} reads {sorted(of_tracks - TRACKSET)} of the TrackSet"


def test_lookahead_imports_no_tracker_implementation():
    imported = _imports(ROOT / "lookahead.py")
    banned = {"uwb_env.tracking.compiled", "uwb_env.tracking.tracker", "uwb_env.tracking.kernels",
              "uwb_env.tracking.imm", "uwb_env.tracking.reference"}  # fmt: skip
    assert not {m for m in imported if m in banned or m.endswith(".compiled")}, sorted(imported)
    assert "uwb_env.tracking.protocol" in imported


def test_no_production_module_imports_the_reference_twins():
    users = [p for p in ROOT.rglob("*.py") if "uwb_env.tracking.reference" in _imports(p)]
    assert users == [], users


def test_unknown_kind_is_a_clear_error():
    with pytest.raises(
        ValueError, match=r"TrackerConfig.kind = 'ukf-phd': must be one of \('imm-lmipda', 'phd', 'pf'\)"
    ):
        TrackerConfig(kind="ukf-phd")
    with pytest.raises(ValueError, match=r"tracker='gm-phd'"):
        gym.make("uwb_env/IndoorSensorSubset-v1", tracker="gm-phd")


@pytest.mark.parametrize("kind", AVAILABLE)
def test_registry_builds_a_protocol_tracker(kind):
    cfg = scenarios.get("indoor-rsn")
    tracker = make_tracker(TrackerConfig(kind=kind), SceneLayout.from_config(cfg))
    assert isinstance(tracker, MultiTargetTracker)
    assert tracker.kind == kind
    assert tracker.filter in ("ukf", "ekf")
    tracker.reset(np.random.default_rng(0))
    assert len(tracker.tracks) == 0
    assert tracker.scored_prediction(0.1, 1) is None


def test_tracker_argument_equals_the_dotted_override_and_the_default():
    """``tracker="imm-lmipda"`` (the default kind) and the override give the same episode as no argument."""
    envs = [
        gym.make("uwb_env/UrbanWaveform-v3"),
        gym.make("uwb_env/UrbanWaveform-v3", tracker="imm-lmipda"),
        gym.make("uwb_env/UrbanWaveform-v3", **{"tracker.kind": "imm-lmipda"}),
    ]
    runs = []
    for env in envs:
        obs, _ = env.reset(seed=3)
        out = [obs]
        for k in range(25):
            obs, reward, *_ = env.step(k % 4)
            out.append(np.append(obs, reward))
        runs.append(np.concatenate([o.ravel() for o in out]))
    np.testing.assert_array_equal(runs[0], runs[1])
    np.testing.assert_array_equal(runs[0], runs[2])


@pytest.mark.parametrize("kind", AVAILABLE)
@pytest.mark.parametrize("scheduler", ["myopic", "random", "lookahead-2"])
def test_every_tracker_runs_in_the_loop(kind, scheduler):
    """Myopic, random and two-step lookahead on IndoorSensorSubset-v1 with each tracker: finite rewards, the person
    held by a confirmed track in most scans."""
    env = gym.make("uwb_env/IndoorSensorSubset-v1", tracker=kind)
    sched = make_scheduler(scheduler)
    obs, _ = env.reset(seed=1)
    sched.reset(1)
    rewards, confirmed, done = [], 0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(sched.act(obs, env.unwrapped))
        rewards.append(reward)
        confirmed += info["confirmed_tracks"] - info["false_tracks"]
        done = terminated or truncated
    assert np.isfinite(rewards).all()
    assert confirmed >= 0.5 * len(rewards)  # the person is tracked most of the episode


@pytest.mark.parametrize("kind", AVAILABLE)
def test_env_checker_passes_with_every_tracker(kind):
    check_env(gym.make("uwb_env/IndoorSensorSubset-v1", tracker=kind).unwrapped, skip_render_check=True)


@pytest.mark.parametrize("q2", [1.0, "pda"])
@pytest.mark.parametrize("kind", AVAILABLE)
def test_lookahead_is_defined_for_every_tracker(kind, q2):
    """The myopic costs exist mid-episode, are finite, and differ between plans (they carry the sensor model);
    with q_2 = "pda" too (the clutter map of range-only impulse measurements).

    The particle filter on seed 3: on seed 2 its cloud falls into the transmitter's blind zone since issue 18's
    recalibration of indoor-rsn's detector (P_D = 0 there for every plan, so every cost ties).
    That is the PF's known attractor (``indoor_rsn.RANGE_PF``), not the seam's: over 6 random-plan runs it loses the
    person once both before the recalibration (seed 5) and after it (seed 2), median error 0.088 / 0.095 m. (On
    seed 3 the VS-IMM confirms its track only at scan 23 of these cyclic plans, before and after: no track, every
    cost ties; it keeps seed 2.)"""
    env = gym.make("uwb_env/IndoorSensorSubset-v1", tracker=kind, lookahead_q2=q2).unwrapped
    env.reset(seed=3 if kind == "pf" else 2)
    for k in range(20):
        env.step(k % env.action_space.n)
    costs = env.lookahead_costs()
    assert np.isfinite(costs).all()
    assert np.ptp(costs) > 0


def test_kind_overrides_apply_to_scenarios():
    cfg = apply_overrides(scenarios.get("indoor-rsn"), {"tracker.kind": "phd"})
    assert cfg.tracker.kind == "phd"


def test_campaign_schemes_name_the_tracker(tmp_path):
    """``SCHEDULER@KIND`` plays each tracker in one paired campaign; each run file carries its tracker's models."""
    from uwb_env.agents.campaign import Campaign, run_campaign

    schemes = (*(f"myopic@{k}" for k in AVAILABLE), "round-robin")
    run_campaign(Campaign("uwb_env/IndoorSensorSubset-v1", schemes, "round-robin", runs=2), tmp_path, progress=False)
    for kind in AVAILABLE:
        header = (tmp_path / "runs" / f"myopic__{kind}" / "seed-0.csv").read_text().splitlines()[0].split(",")
        env = gym.make("uwb_env/IndoorSensorSubset-v1", tracker=kind).unwrapped
        assert header[-len(env.sim.tracker.model_names) :] == [f"mu:{m}" for m in env.sim.tracker.model_names]
