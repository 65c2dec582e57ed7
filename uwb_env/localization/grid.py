r"""Forward-solving grid localization on soft bistatic-delay information (seed 004 section 2.7).

Space is cut into P pixels z_i. Under the single-bounce model a person in pixel i shows on link m (transmitter t_m,
receiver r_m) in range bin (eq. 16)

    k_i^m = ceil((|t_m - z_i| + |z_i - r_m| - |t_m - r_m|) / d_k),

d_k = c T the distance light travels in one bin; bins count the excess delay over the direct path, bin k holding
((k - 1) T, k T] (bin 0 ends at the direct path), so eq. 16's ceil is the bin of the excess delay exactly.

Each link contributes a per-bin information [A^m]_k and the presence image is the p-norm over links (eq. 17)

    l_i = (sum_m ([A^m]_{k_i^m})^p)^(1/p),          p = 0.2 in the seed; p = 0 counts the non-zero terms.

* Soft information (eq. 18): [A^m]_k = (alpha_k - alpha_{k-1})^+ with alpha_k = P(X_k = 1 | O, lambda) from the
  HMM and alpha_{-1} = 0 (the seed's alpha_0 = 0 with bins from 1): the posterior's rise at bin k, a soft
  probability that the person's bistatic delay falls in bin k.
* Range only (eq. 19): [A^m]_k = 1 if k = k_hat_* of link m, else 0 (the extracted text reads "i = k_hat_*"; the
  index compared with the estimate is the pixel's bin k_i^m). A link without an estimate (k_hat = -1) gives 0.

A pixel whose bin falls outside the observed window gets 0 from that link. The image is smoothed by a 2-D Gaussian
filter (the seed gives no width; the caller chooses it) and the person is put at the brightest pixel.
With p < 1 a small contribution counts for much (0.01^0.2 = 0.4): the image rewards pixels that many links support
over pixels that one link supports strongly.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter

from uwb_env.typing import FloatArray, IntArray


def pixel_grid(x_edges: tuple[float, float], y_edges: tuple[float, float], step: float) -> tuple[FloatArray, ...]:
    """Pixel centres of a rectangle: xs ``(nx,)``, ys ``(ny,)`` and points ``(ny * nx, 2)`` (row-major in y)."""
    xs = np.arange(x_edges[0] + step / 2, x_edges[1], step)
    ys = np.arange(y_edges[0] + step / 2, y_edges[1], step)
    X, Y = np.meshgrid(xs, ys)
    return xs, ys, np.stack([X.ravel(), Y.ravel()], axis=-1)


def bistatic_bins(points: FloatArray, tx: FloatArray, rx: FloatArray, bin_m: float) -> IntArray:
    """Eq. 16: ``(P, M)`` excess-delay bins of ``points`` ``(P, 2)`` on links ``tx``, ``rx`` ``(M, 2)``."""
    z = np.asarray(points, dtype=float)[:, None, :]
    tx, rx = np.asarray(tx, dtype=float), np.asarray(rx, dtype=float)
    excess = np.linalg.norm(z - tx, axis=-1) + np.linalg.norm(z - rx, axis=-1) - np.linalg.norm(tx - rx, axis=-1)
    return np.ceil(excess / bin_m - 1e-9).astype(np.int64)


def soft_information(alpha: FloatArray) -> FloatArray:
    """Eq. 18: (alpha_k - alpha_{k-1})^+ along the last axis, alpha_{-1} = 0."""
    alpha = np.asarray(alpha, dtype=float)
    return np.maximum(np.diff(alpha, axis=-1, prepend=0.0), 0.0)


def range_only_information(k_hat: IntArray, n_bins: int) -> FloatArray:
    """Eq. 19: one-hot ``(..., N)`` at each link's estimate (all zeros where k_hat = -1 or >= N)."""
    k_hat = np.asarray(k_hat)
    return (np.arange(n_bins) == k_hat[..., None]).astype(float)


def p_norm(values: FloatArray, p: float, axis: int = -1) -> FloatArray:
    """(sum v^p)^(1/p) of non-negative values along ``axis``; p = 0: the number of non-zero values."""
    v = np.asarray(values, dtype=float)
    if p == 0:
        return np.count_nonzero(v > 0, axis=axis).astype(float)
    return np.sum(v**p, axis=axis) ** (1.0 / p)


def presence_image(info: FloatArray, bins: IntArray, p: float = 0.2) -> FloatArray:
    """Eq. 17 for a batch: ``info`` ``(..., M, N)`` per-link bin information, ``bins`` ``(P, M)`` -> ``(..., P)``."""
    info = np.asarray(info, dtype=float)
    M, N = info.shape[-2:]
    bins = np.asarray(bins)
    inside = (bins >= 0) & (bins < N)
    a = info[..., np.arange(M), np.clip(bins, 0, N - 1)]  # (..., P, M)
    return p_norm(np.where(inside, a, 0.0), p, axis=-1)


def locate_on_grid(
    image: FloatArray, xs: FloatArray, ys: FloatArray, smooth_px: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """The brightest pixel of images ``(..., ny * nx)`` after a Gaussian filter of std ``smooth_px`` pixels.

    Returns the positions ``(..., 2)`` and the filtered images ``(..., ny, nx)``.
    """
    img = np.asarray(image, dtype=float).reshape(*np.shape(image)[:-1], ys.size, xs.size)
    if smooth_px > 0:
        sig = (0,) * (img.ndim - 2) + (smooth_px, smooth_px)
        img = gaussian_filter(img, sig, mode="constant")
    flat = img.reshape(*img.shape[:-2], -1)
    idx = np.argmax(flat, axis=-1)
    iy, ix = np.unravel_index(idx, (ys.size, xs.size))
    return np.stack([xs[ix], ys[iy]], axis=-1), img
