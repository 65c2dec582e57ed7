r"""Simulated cluttered UWB channel impulse responses for seed 004's bistatic-delay replica (McCracken & Patwari).

The seed measures with two Time Domain P220 radios (3.1-5.3 GHz) in two rooms, four radio positions per room (the
M = 6 pairs), a person standing still at grid points 90 cm apart, 10 empty-room captures per pair and 10 captures
per point, range bins of T = 1 ns (section 3). It gives no link budget or channel model beyond that; what follows
is our choice, stated so the replica can be judged.

Signal. Complex baseband of a Gaussian pulse of std 0.22 ns (a -10 dB bandwidth of 2.2 GHz, the P220's band) at a
carrier of 4.3 GHz, sampled every T / 10. A path of excess delay tau (ns, over the direct path) and complex gain a
adds a exp(-j 2 pi f_c tau_abs) g(t - tau). Amplitudes are in units of lambda / (4 pi) [1/m]: the direct path of a
d0 m link is 1 / d0 (Friis), the single-bounce echo of a scatterer of radar cross-section sigma at distances d_t,
d_r is sqrt(sigma / (4 pi)) / (d_t d_r) (bistatic radar equation), a first-order wall reflection rho / d_image.

Static channel of a link (the empty room): the direct path; the four first-order wall reflections (image method,
amplitude coefficient ``wall_rho``, phase pi); dense diffuse multipath, Poisson arrivals of ``arrival_per_ns`` in
excess delay, Rayleigh amplitudes of mean power P0 exp(-tau / decay_ns), uniform phases, with a total diffuse-to-
direct energy ratio ``diffuse_ratio_db`` (P0 = K |a_0|^2 / (rate decay)).

Capture-to-capture variation (both sessions alike): complex white noise of std ``noise_std`` per sample (set by the
direct-path SNR of a 5 m link, ``los_snr_db_5m``, the P220's pulse integration); a common timing jitter of std
``jitter_ps`` on every path; a small complex fluctuation of every static path (std ``path_fluct`` relative: fans,
vibration); the person's paths sway (phase std ``sway_rad``, amplitude std ``sway_amp``): the person "remains as
motionless as possible".

Calibration versus measurement (what makes the background not subtract): per measurement session a common gain
drift (std ``gain_drift_db``) and Poisson(``clutter_rate``) clutter changes, each a scatterer (radar cross-section
log-uniform in ``clutter_rcs``) at a uniform position in the room grown by ``clutter_margin`` m on every side
(outside the room 5 dB of wall loss each way), present in only one of the two sessions (things moved, people
passing): Poisson(``clutter_rate`` / 2) in the link's calibration session, a fresh Poisson(``clutter_rate``) in
every measurement, so that changes also appear before the person's bistatic delay.

The person (a point scatterer at the grid point): a direct echo of radar cross-section log-normal around
``person_rcs`` (3 dB std); the person's share of the reverberant field: the body, lit by the room's diffuse field,
re-scatters a fraction sigma / A of it, A = 4 V / (c tau_decay) the room's equivalent absorption area (Sabine; a
height of ``height`` m), so from tau_* on a dense Poisson set of paths (the room's arrival rate) of mean power
(sigma / A) P0 exp(-tau / decay) joins the static diffuse paths, a change that lasts over the whole tail whatever
the person's position (the seed: "r_k will experience changes ... for many k >= k_*"; ``reverb_scale`` multiplies
sigma / A for sensitivity studies); the body blocks the static
paths later than tau_* that cross it: a path of length L crosses a body of width w with probability ~ w L / S in a
room of floor area S (a random ray in 2-D), so each is attenuated by N(``body_loss_db``, 3) dB with probability
min(1, ``body_width`` (d0 + c tau) / S); a person within 0.3 m of excess path of the direct path halves it.

Bins: bin k (k = 0 .. n_bins - 1) holds the excess delays ((k - 1) T, k T], so the person's bin is
k_* = ceil(tau_* / T) (the convention of eq. 16); ``pre_bins`` bins before bin 0 hold noise only (Zetik's noise
level). r_k (eq. 3) = sum of |h|^2 dt over the bin's samples.
"""

from __future__ import annotations

import dataclasses

import numba as nb
import numpy as np

from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.typing import FloatArray, IntArray

C_M_PER_NS = SPEED_OF_LIGHT_MPS * 1e-9


@dataclasses.dataclass(frozen=True)
class CirConfig:
    """Sampling, pulse, noise and session parameters (module docstring)."""

    bin_ns: float = 1.0
    n_bins: int = 40
    sub: int = 10
    pre_bins: int = 10
    fc_ghz: float = 4.3
    pulse_std_ns: float = 0.22
    los_snr_db_5m: float = 40.0
    jitter_ps: float = 5.0
    path_fluct: float = 0.03
    sway_rad: float = 0.3
    sway_amp: float = 0.1
    gain_drift_db: float = 0.1
    n_cal: int = 10
    n_test: int = 10

    @property
    def dt_ns(self) -> float:
        """Sample spacing [ns]."""
        return self.bin_ns / self.sub

    @property
    def n_samples(self) -> int:
        """Samples per capture."""
        return (self.pre_bins + self.n_bins) * self.sub

    @property
    def noise_std(self) -> float:
        """Complex noise std per sample: the 5 m direct path's amplitude 1/5 at ``los_snr_db_5m``."""
        return 0.2 / 10 ** (self.los_snr_db_5m / 20)

    def sample_times(self) -> FloatArray:
        """Excess delay [ns] of every sample (the middle of its sub-interval)."""
        return -(self.pre_bins + 1) * self.bin_ns + (np.arange(self.n_samples) + 0.5) * self.dt_ns

    def bin_of_sample(self) -> IntArray:
        """Range bin of every sample (negative before bin 0)."""
        return np.arange(self.n_samples) // self.sub - self.pre_bins

    def noise_slice(self) -> slice:
        """The noise-only samples: the pre-bins except the two before bin 0 (the direct pulse's leading edge)."""
        return slice(0, (self.pre_bins - 2) * self.sub)


@dataclasses.dataclass(frozen=True)
class RoomConfig:
    """A room: its rectangle (centred at 0), four radio positions, the person's points and its channel."""

    name: str
    size: tuple[float, float]
    radios: FloatArray  # (4, 2)
    points: FloatArray  # (P, 2)
    diffuse_ratio_db: float = 0.0
    decay_ns: float = 12.0
    arrival_per_ns: float = 2.0
    wall_rho: float = 0.5
    clutter_rate: float = 1.5
    clutter_rcs: tuple[float, float] = (0.02, 0.3)
    clutter_margin: float = 1.5
    person_rcs: float = 0.5
    height: float = 3.0
    body_width: float = 0.4
    body_loss_db: float = 10.0
    reverb_scale: float = 1.0

    def absorption_area(self) -> float:
        """Equivalent absorption area A = 4 V / (c tau_decay) [m^2] of the room (Sabine's relation)."""
        return 4.0 * self.size[0] * self.size[1] * self.height / (C_M_PER_NS * self.decay_ns)

    def links(self) -> tuple[FloatArray, FloatArray]:
        """The M = 6 pairs of the four radios: tx ``(6, 2)`` (the lower index) and rx ``(6, 2)``."""
        i, j = np.triu_indices(len(self.radios), k=1)
        return np.asarray(self.radios)[i], np.asarray(self.radios)[j]


def point_grid(nx: int, ny: int, spacing: float = 0.9) -> FloatArray:
    """``(nx * ny, 2)`` points ``spacing`` apart centred at the origin."""
    xs = (np.arange(nx) - (nx - 1) / 2) * spacing
    ys = (np.arange(ny) - (ny - 1) / 2) * spacing
    X, Y = np.meshgrid(xs, ys)
    return np.stack([X.ravel(), Y.ravel()], axis=-1)


@dataclasses.dataclass(frozen=True)
class LinkData:
    """Simulated captures of one room: M links, P person points.

    cal: ``(M, n_cal, S)`` complex; test: ``(M, P, n_test, S)`` complex; excess_ns ``(M, P)`` the true tau_*;
    k_true ``(M, P)`` = ceil(tau_* / T).
    """

    cal: np.ndarray
    test: np.ndarray
    excess_ns: FloatArray
    k_true: IntArray


@nb.njit(cache=True, nogil=True)
def _render(delays, amps, t0, dt, n_samples, sigma, out):  # pragma: no cover - compiled
    """out[c, n] += sum_i amps[c, i] g(t_n - delays[c, i]), g a unit Gaussian of std sigma, t_n = t0 + (n + .5) dt."""
    C, Pn = delays.shape
    half = 5.0 * sigma
    for c in range(C):
        for i in range(Pn):
            a = amps[c, i]
            if a == 0:
                continue
            tau = delays[c, i]
            lo = max(int(np.floor((tau - half - t0) / dt - 0.5)), 0)
            hi = min(int(np.ceil((tau + half - t0) / dt - 0.5)) + 1, n_samples)
            for n in range(lo, hi):
                x = (t0 + (n + 0.5) * dt - tau) / sigma
                out[c, n] += a * np.exp(-0.5 * x * x)


def bin_energy(cir: np.ndarray, cfg: CirConfig) -> FloatArray:
    """Eq. 3: r_k = sum |h|^2 dt over each bin k = 0 .. n_bins - 1, ``(..., S)`` -> ``(..., n_bins)``."""
    e = np.square(np.abs(cir[..., cfg.pre_bins * cfg.sub :])) * cfg.dt_ns
    return e.reshape(*e.shape[:-1], cfg.n_bins, cfg.sub).sum(axis=-1)


def _bistatic(z: FloatArray, tx: FloatArray, rx: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    dt = np.linalg.norm(z - tx, axis=-1)
    dr = np.linalg.norm(z - rx, axis=-1)
    return dt, dr, dt + dr - np.linalg.norm(tx - rx)


def _static_paths(rng: np.random.Generator, room: RoomConfig, cfg: CirConfig, tx, rx) -> tuple[FloatArray, ...]:
    d0 = float(np.linalg.norm(tx - rx))
    a0 = 1.0 / d0
    delays, amps = [0.0], [a0 * np.exp(-2j * np.pi * cfg.fc_ghz * d0 / C_M_PER_NS)]
    lx, ly = room.size[0] / 2, room.size[1] / 2
    for axis, wall in ((0, -lx), (0, lx), (1, -ly), (1, ly)):
        img = np.array(tx, dtype=float)
        img[axis] = 2 * wall - img[axis]
        d = float(np.linalg.norm(img - rx))
        delays.append((d - d0) / C_M_PER_NS)
        amps.append(-room.wall_rho / d * np.exp(-2j * np.pi * cfg.fc_ghz * d / C_M_PER_NS))
    span = (cfg.n_bins + 5) * cfg.bin_ns
    n = rng.poisson(room.arrival_per_ns * span)
    tau = np.sort(rng.uniform(0.05, span, n))
    p0 = 10 ** (room.diffuse_ratio_db / 10) * a0**2 / (room.arrival_per_ns * room.decay_ns)
    a = np.sqrt(p0 * np.exp(-tau / room.decay_ns) / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    return np.concatenate([delays, tau]), np.concatenate([amps, a]), p0


def _scatterer(cfg: CirConfig, z, tx, rx, rcs, extra_loss=1.0) -> tuple[float, complex]:
    dt, dr, exc = _bistatic(np.asarray(z), tx, rx)
    d = dt + dr
    amp = extra_loss * np.sqrt(rcs / (4 * np.pi)) / (dt * dr)
    return exc / C_M_PER_NS, amp * np.exp(-2j * np.pi * cfg.fc_ghz * d / C_M_PER_NS)


def _clutter(
    rng: np.random.Generator, room: RoomConfig, cfg: CirConfig, tx, rx, rate_scale: float = 1.0
) -> tuple[FloatArray, FloatArray]:
    """One session's clutter-change scatterers: delays, amplitudes (module docstring)."""
    n = rng.poisson(room.clutter_rate * rate_scale)
    lx, ly = room.size[0] / 2, room.size[1] / 2
    m = room.clutter_margin
    out_d, out_a = [], []
    for _ in range(n):
        z = rng.uniform([-lx - m, -ly - m], [lx + m, ly + m])
        outside = abs(z[0]) > lx or abs(z[1]) > ly
        rcs = np.exp(rng.uniform(*np.log(room.clutter_rcs)))
        d, a = _scatterer(cfg, z, tx, rx, rcs, 10 ** (-10 / 20) if outside else 1.0)
        out_d.append(d)
        out_a.append(a)
    return np.array(out_d, dtype=float), np.array(out_a, dtype=complex)


def _captures(rng, cfg: CirConfig, delays, amps, fixed_d, fixed_a, sway_d, sway_a, n_cap) -> np.ndarray:
    """``(n_cap, S)`` captures of static paths (fluctuating), fixed extra paths and swaying person paths."""
    gain = 10 ** (rng.normal(0.0, cfg.gain_drift_db) / 20)
    jit = rng.normal(0.0, cfg.jitter_ps * 1e-3, (n_cap, 1))
    fl = 1.0 + cfg.path_fluct * (
        rng.standard_normal((n_cap, delays.size)) + 1j * rng.standard_normal((n_cap, delays.size))
    ) / np.sqrt(2)
    sw = (1.0 + cfg.sway_amp * rng.standard_normal((n_cap, sway_d.size))) * np.exp(
        1j * cfg.sway_rad * rng.standard_normal((n_cap, sway_d.size))
    )
    d = (
        np.concatenate(
            [
                np.broadcast_to(delays, (n_cap, delays.size)),
                np.broadcast_to(fixed_d, (n_cap, fixed_d.size)),
                np.broadcast_to(sway_d, (n_cap, sway_d.size)),
            ],
            axis=1,
        )
        + jit
    )
    a = np.concatenate([amps * fl, np.broadcast_to(fixed_a, (n_cap, fixed_a.size)), sway_a * sw], axis=1)
    a = gain * a * np.exp(-2j * np.pi * cfg.fc_ghz * jit)  # the jitter's carrier phase
    out = (
        cfg.noise_std
        / np.sqrt(2)
        * (rng.standard_normal((n_cap, cfg.n_samples)) + 1j * rng.standard_normal((n_cap, cfg.n_samples)))
    )
    _render(
        np.ascontiguousarray(d),
        np.ascontiguousarray(a.astype(np.complex128)),
        -(cfg.pre_bins + 1) * cfg.bin_ns,
        cfg.dt_ns,
        cfg.n_samples,
        cfg.pulse_std_ns,
        out,
    )
    return out


def simulate_room(rng: np.random.Generator, room: RoomConfig, cfg: CirConfig) -> LinkData:
    """Calibration and person captures of every link and point of ``room`` (module docstring)."""
    tx_all, rx_all = room.links()
    M, P = len(tx_all), len(room.points)
    cal = np.empty((M, cfg.n_cal, cfg.n_samples), dtype=complex)
    test = np.empty((M, P, cfg.n_test, cfg.n_samples), dtype=complex)
    excess = np.empty((M, P))
    none_d, none_a = np.zeros(0), np.zeros(0, dtype=complex)
    for m in range(M):
        tx, rx = tx_all[m], rx_all[m]
        delays, amps, p0 = _static_paths(rng, room, cfg, tx, rx)
        span = (cfg.n_bins + 5) * cfg.bin_ns
        d0 = float(np.linalg.norm(tx - rx))
        # one calibration session per link (section 3.1), with its own clutter (gone by the measurements)
        cd, ca = _clutter(rng, room, cfg, tx, rx, rate_scale=0.5)
        cal[m] = _captures(rng, cfg, delays, amps, cd, ca, none_d, none_a, cfg.n_cal)
        for p in range(P):
            z = room.points[p]
            rcs = room.person_rcs * 10 ** (rng.normal(0.0, 3.0) / 10)
            tau, a_star = _scatterer(cfg, z, tx, rx, rcs)
            excess[m, p] = tau
            # the person's share of the reverberant field, from tau_* on
            n_sec = rng.poisson(room.arrival_per_ns * max(span - tau, 0.0))
            ts = rng.uniform(tau, span, n_sec) if n_sec else np.zeros(0)
            ps = room.reverb_scale * rcs / room.absorption_area() * p0 * np.exp(-ts / room.decay_ns)
            as_ = np.sqrt(ps / 2) * (rng.standard_normal(n_sec) + 1j * rng.standard_normal(n_sec))
            # shadowing of later static paths, blocking of the direct path
            amp_m = amps.copy()
            p_block = np.minimum(room.body_width * (d0 + delays * C_M_PER_NS) / (room.size[0] * room.size[1]), 1.0)
            later = (delays > tau) & (rng.random(delays.size) < p_block)
            amp_m[later] *= 10 ** (-rng.normal(room.body_loss_db, 3.0, later.sum()) / 20)
            if tau * C_M_PER_NS < 0.3:
                amp_m[0] *= 0.5
            # this session's clutter: the calibration-only changes are gone, new ones may appear
            td, ta = _clutter(rng, room, cfg, tx, rx)
            test[m, p] = _captures(
                rng,
                cfg,
                delays,
                amp_m,
                td,
                ta,
                np.concatenate([[tau], ts]),
                np.concatenate([[a_star], as_]),
                cfg.n_test,
            )
    k_true = np.ceil(excess / cfg.bin_ns - 1e-9).astype(np.int64)
    return LinkData(cal, test, excess, k_true)
