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

Calibration versus measurement. Per measurement session a common gain drift of std ``gain_drift_db`` (default
0.03 dB: amplifier gain moves by ~0.01-0.04 dB per degree C and a lab drifts by about a degree over a session's
minutes; 0.1 dB, 2.3 % of energy against a capture-to-capture spread of r_k of about 4 %, moves every bin's mean
and is a persistent change from bin 1 on, which no first-change detector can tell from a person), and clutter
changes, each an object (radar cross-section log-uniform in ``clutter_rcs``) present in only one of the two
sessions: Poisson(``clutter_rate``) outside the room (uniform over a band ``clutter_margin`` m wide around the
walls: people passing in the corridor, doors; 5 dB of wall loss each way, the seed's measured interior wall) and
Poisson(``inroom_clutter_rate``) inside it (default 0: in the seed's protocol nothing but the person moves in the
room; the room's furniture is static clutter, part of the static channel above). Each session draws its own:
rate / 2 in the link's calibration session, the full rate afresh in every measurement, so that changes also
appear before the person's bistatic delay.

An object (the person or a clutter change) at z changes the link in three ways, all from its bistatic delay
tau_z on (nothing reaches it earlier; the seed: "the person's body will cause a new multipath component at the
receiver as well as affect existing multipath components ... many alpha_i for tau_i >= tau_*"):

* its single-bounce echo (bistatic radar equation);
* its room-multipath tail: the object is lit by the room's multipath as well as by the transmitter, and re-radiates
  through the room as well as straight to the receiver. With the room's diffuse-to-direct ratio K of the link
  (diffuse level K / d0^2 at every point), the leg tx -> z sees K_t = K (d_t / d0)^2, the leg z -> rx
  K_r = K (d_r / d0)^2, so the paths through the object carry (1 + K_t)(1 + K_r) - 1 times the echo's energy
  beyond the echo: a Poisson set (the room's arrival rate) from tau_z on, exponential decay ``decay_ns``
  (``reverb_scale`` multiplies it for sensitivity studies);
* the static paths it perturbs: a diffuse path of length L = d0 + c tau (tau > tau_z) is the sum of many rays, of
  which a share f = min(1, X L / V) crosses the object (the mean-chord result for random rays in a room of volume
  V; X the object's cross-section: for the person the body, ``body_width`` x ``body_height``, grown by the first
  Fresnel radius r_F = sqrt(lambda d_t d_r / (d_t + d_r)) on every side, ~2.5 m^2; for a clutter object its
  radar cross-section); the perturbed rays change by a complex factor of mean power ``perturb_power`` (0.5: a
  10 dB shadow inside the body, partial diffraction in the Fresnel zone), so the path changes by a complex
  Gaussian da of power f perturb_power P0 exp(-tau / decay). The five specular paths (direct, four walls) are
  checked by geometry: within ``body_width`` / 2 of the object the path loses ``body_loss_db``, fading linearly to
  0 dB at r_F further out. An object outside the room perturbs no static path (the room's paths do not leave it).

The person's echo, tail and changes da sway together from capture to capture (the body's scattered field moves
with the body); a clutter object's are fixed. The person's echo has radar cross-section log-normal around
``person_rcs`` (3 dB std).

Before this model the person's later change was only a sigma / A share of the diffuse
field (-23 dB of it) and the shadowing of 1.3 % of the paths per metre of path: the change at tau_* was the echo
alone, O after it barely above O before (medians 1-2 against 0.5-1), and thresholding the echo beat the HMM.

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
    gain_drift_db: float = 0.03
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
    inroom_clutter_rate: float = 0.0
    clutter_rcs: tuple[float, float] = (0.02, 0.3)
    clutter_margin: float = 1.5
    person_rcs: float = 0.5
    height: float = 3.0
    body_width: float = 0.4
    body_loss_db: float = 10.0
    body_height: float = 1.7
    perturb_power: float = 0.5
    reverb_scale: float = 1.0

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


def specular_polylines(room: RoomConfig, tx, rx) -> list[FloatArray]:
    """The direct path and the four first-order wall reflections as polylines ``(n, 2)``, in _static_paths' order."""
    tx, rx = np.asarray(tx, dtype=float), np.asarray(rx, dtype=float)
    out = [np.stack([tx, rx])]
    lx, ly = room.size[0] / 2, room.size[1] / 2
    for axis, wall in ((0, -lx), (0, lx), (1, -ly), (1, ly)):
        img = tx.copy()
        img[axis] = 2 * wall - img[axis]
        t = (wall - img[axis]) / (rx[axis] - img[axis])  # where image -> rx meets the wall
        out.append(np.stack([tx, img + t * (rx - img), rx]))
    return out


def _distance_to_polyline(z: FloatArray, poly: FloatArray) -> float:
    a, b = poly[:-1], poly[1:]
    ab = b - a
    t = np.clip(np.sum((z - a) * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-12), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab - z, axis=-1)))


def fresnel_radius(cfg: CirConfig, d_t: float, d_r: float) -> float:
    """First Fresnel zone radius sqrt(lambda d_t d_r / (d_t + d_r)) [m] at the carrier."""
    lam = C_M_PER_NS / cfg.fc_ghz
    return float(np.sqrt(lam * d_t * d_r / (d_t + d_r)))


def object_paths(
    rng: np.random.Generator,
    room: RoomConfig,
    cfg: CirConfig,
    tx,
    rx,
    z,
    rcs: float,
    cross_section: float,
    width: float,
    static: tuple[FloatArray, FloatArray, float],
    extra_loss: float = 1.0,
    tail_scale: float = 1.0,
    inside: bool = True,
) -> tuple[float, FloatArray, FloatArray]:
    """Every change an object at ``z`` makes to a link's CIR, as added paths (module docstring, "an object").

    ``static``: the link's static paths (delays, amplitudes, P0) from :func:`_static_paths`. Returns the object's
    bistatic delay tau_* [ns] and the added paths' delays and complex amplitudes: its single-bounce echo, its
    room-multipath tail from tau_* on, and the change it makes to every static path it perturbs (rendering is
    linear, so a path changed from a to a + da is the static path plus an added path da at the same delay).
    An object outside the room (``inside`` False; ``extra_loss`` the walls' amplitude loss on its echo) perturbs no
    static path: the room's paths do not leave it.
    """
    delays, amps, p0 = static
    tx, rx, z = (np.asarray(v, dtype=float) for v in (tx, rx, z))
    d_t, d_r, _ = _bistatic(z, tx, rx)
    d0 = float(np.linalg.norm(tx - rx))
    tau, a_star = _scatterer(cfg, z, tx, rx, rcs, extra_loss)
    out_d, out_a = [np.array([tau])], [np.array([a_star])]
    # the object's room-multipath tail: lit and re-radiated through the room's diffuse field on each leg
    K = 10 ** (room.diffuse_ratio_db / 10)
    k_p = (1 + K * (d_t / d0) ** 2) * (1 + K * (d_r / d0) ** 2) - 1
    span = (cfg.n_bins + 5) * cfg.bin_ns
    n_tail = rng.poisson(room.arrival_per_ns * max(span - tau, 0.0))
    ts = rng.uniform(tau, span, n_tail) if n_tail else np.zeros(0)
    e_tail = tail_scale * k_p * abs(a_star) ** 2  # the tail's expected energy
    ps = e_tail / (room.arrival_per_ns * room.decay_ns) * np.exp(-(ts - tau) / room.decay_ns)
    out_d.append(ts)
    out_a.append(np.sqrt(ps / 2) * (rng.standard_normal(n_tail) + 1j * rng.standard_normal(n_tail)))
    if not inside:
        return tau, np.concatenate(out_d), np.concatenate(out_a).astype(complex)
    # the specular paths (direct, four walls): shadowed by geometry, the body's loss fading out over a Fresnel radius
    r_f = fresnel_radius(cfg, d_t, d_r)
    for i, poly in enumerate(specular_polylines(room, tx, rx)):
        clear = _distance_to_polyline(z, poly) - width / 2
        if clear < r_f:
            loss_db = room.body_loss_db * min(1.0, 1.0 - clear / r_f)
            out_d.append(delays[i : i + 1])
            out_a.append(amps[i : i + 1] * (10 ** (-loss_db / 20) - 1.0))
    # the dense diffuse paths later than tau_*: the share of their rays crossing the object (mean chord argument)
    diff = np.arange(delays.size) >= 5
    later = diff & (delays > tau)
    length = d0 + delays[later] * C_M_PER_NS
    f = np.minimum(cross_section * length / (room.size[0] * room.size[1] * room.height), 1.0)
    p_i = p0 * np.exp(-delays[later] / room.decay_ns)
    n = int(later.sum())
    da = np.sqrt(f * room.perturb_power * p_i / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    out_d.append(delays[later])
    out_a.append(da)
    return tau, np.concatenate(out_d), np.concatenate(out_a).astype(complex)


def _clutter(
    rng: np.random.Generator,
    room: RoomConfig,
    cfg: CirConfig,
    tx,
    rx,
    static: tuple[FloatArray, FloatArray, float],
    rate_scale: float = 1.0,
) -> tuple[FloatArray, FloatArray]:
    """One session's clutter-change objects, outside the room and (if any) inside it: their added paths."""
    lx, ly = room.size[0] / 2, room.size[1] / 2
    m = room.clutter_margin
    out_d, out_a = [np.zeros(0)], [np.zeros(0, dtype=complex)]
    n_out = rng.poisson(room.clutter_rate * rate_scale)
    n_in = rng.poisson(room.inroom_clutter_rate * rate_scale)
    for j in range(n_out + n_in):
        if j < n_out:  # uniform over the band outside the walls
            while True:
                z = rng.uniform([-lx - m, -ly - m], [lx + m, ly + m])
                if abs(z[0]) > lx or abs(z[1]) > ly:
                    break
        else:
            z = rng.uniform([-lx, -ly], [lx, ly])
        inside = j >= n_out
        rcs = np.exp(rng.uniform(*np.log(room.clutter_rcs)))
        # an object of radar cross-section sigma: geometric cross-section ~ sigma, width ~ sqrt(sigma)
        _, d, a = object_paths(
            rng, room, cfg, tx, rx, z, rcs, rcs, np.sqrt(rcs), static, 1.0 if inside else 10 ** (-10 / 20),
            inside=inside,
        )  # fmt: skip
        out_d.append(d)
        out_a.append(a)
    return np.concatenate(out_d), np.concatenate(out_a)


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
    for m in range(M):
        tx, rx = tx_all[m], rx_all[m]
        static = _static_paths(rng, room, cfg, tx, rx)
        delays, amps, _ = static
        # one calibration session per link (section 3.1), with its own clutter (gone by the measurements)
        cd, ca = _clutter(rng, room, cfg, tx, rx, static, rate_scale=0.5)
        cal[m] = _captures(rng, cfg, delays, amps, cd, ca, np.zeros(0), np.zeros(0, dtype=complex), cfg.n_cal)
        for p in range(P):
            z = room.points[p]
            rcs = room.person_rcs * 10 ** (rng.normal(0.0, 3.0) / 10)
            d_t, d_r, _ = _bistatic(np.asarray(z), tx, rx)
            r_f = fresnel_radius(cfg, float(d_t), float(d_r))
            cross = (room.body_width + 2 * r_f) * (room.body_height + 2 * r_f)
            tau, pd, pa = object_paths(
                rng, room, cfg, tx, rx, z, rcs, cross, room.body_width, static, tail_scale=room.reverb_scale
            )
            excess[m, p] = tau
            # this session's clutter: the calibration-only changes are gone, new ones may appear
            td, ta = _clutter(rng, room, cfg, tx, rx, static)
            test[m, p] = _captures(rng, cfg, delays, amps, td, ta, pd, pa, cfg.n_test)
    k_true = np.ceil(excess / cfg.bin_ns - 1e-9).astype(np.int64)
    return LinkData(cal, test, excess, k_true)
