"""Wrinkle wavelengths: a scalar field sampled along a line, and its dominant wavelength by FFT.

A wrinkled sheet's deflection along a line across the wrinkles is close to a sinusoid
A sin(2π s/λ + φ); the wavelength λ is read off the peak of the windowed, zero-padded discrete
Fourier transform of the samples, refined by a parabola through the peak and its neighbours
(the peak of a Hann-windowed sinusoid is nearly a parabola in the log-magnitude). The samples are
gathered from all ranks, so the numbers do not depend on the number of ranks.
"""

from __future__ import annotations

from collections.abc import Sequence

from mpi4py import MPI

import dolfinx.fem
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

#: Zero padding of the FFT: the spectrum is sampled PAD times finer than 1/(length).
PAD = 32


def line_values(u: dolfinx.fem.Function[np.float64], points: np.ndarray) -> np.ndarray:
    """U at ``points`` (n × 2 or n × 3), the mean over the owned cells containing each point.

    Collective; NaN where no cell contains a point.
    """
    mesh = u.function_space.mesh
    tdim = mesh.topology.dim
    owned = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
    tree = dolfinx.geometry.bb_tree(mesh, tdim, entities=owned)
    xyz = np.zeros((len(points), 3), dtype=mesh.geometry.x.dtype)
    xyz[:, : np.shape(points)[1]] = points
    candidates = dolfinx.geometry.compute_collisions_points(tree, xyz)
    colliding = dolfinx.geometry.compute_colliding_cells(mesh, candidates, xyz)
    total = np.zeros(len(xyz))
    count = np.zeros(len(xyz))
    for i in range(len(xyz)):
        cells = colliding.links(i)
        if len(cells):
            values = u.eval(np.repeat(xyz[i : i + 1], len(cells), axis=0), cells)
            total[i] = float(np.sum(values))
            count[i] = len(cells)
    total = mesh.comm.allreduce(total, op=MPI.SUM)
    count = mesh.comm.allreduce(count, op=MPI.SUM)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def dominant_wavelength(s: npt.ArrayLike, values: npt.ArrayLike) -> float:
    """The wavelength of the strongest Fourier component of ``values`` sampled at uniform ``s``.

    The mean is removed, a Hann window applied and the FFT zero-padded :data:`PAD` times; the
    peak frequency is refined by a parabola through the log-magnitudes at the peak and its two
    neighbours. NaN for a constant signal.
    """
    s_arr = np.asarray(s, dtype=float)
    v = np.asarray(values, dtype=float)
    v = (v - v.mean()) * np.hanning(v.size)
    if not np.any(v):
        return float("nan")
    spacing = (s_arr[-1] - s_arr[0]) / (s_arr.size - 1)
    size = PAD * s_arr.size
    spectrum = np.abs(np.fft.rfft(v, size))
    k = int(np.argmax(spectrum[1:])) + 1
    shift = 0.0
    if 0 < k < spectrum.size - 1:
        a, b, c = np.log(spectrum[k - 1 : k + 2] + 1e-300)
        denominator = a - 2 * b + c
        shift = 0.5 * (a - c) / denominator if denominator else 0.0
    frequency = (k + shift) / (size * spacing)
    return float(1.0 / frequency)


def amplitude(values: npt.ArrayLike) -> float:
    """√2 times the root mean square of ``values`` about their mean: A for A sin(…)."""
    v = np.asarray(values, dtype=float)
    return float(np.sqrt(2.0) * np.std(v))


def wrinkle_profile(
    u: dolfinx.fem.Function[np.float64],
    start: Sequence[float],
    end: Sequence[float],
    samples: int = 400,
) -> dict[str, float]:
    """Wavelength and amplitude of ``u`` along the segment from ``start`` to ``end`` (collective)."""
    t = np.linspace(0.0, 1.0, samples)
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    points = a[None, :] + t[:, None] * (b - a)[None, :]
    values = line_values(u, points)
    keep = np.isfinite(values)
    s = t[keep] * float(np.linalg.norm(b - a))
    return {
        "wavelength": dominant_wavelength(s, values[keep]),
        "amplitude": amplitude(values[keep]),
    }


__all__ = ["PAD", "amplitude", "dominant_wavelength", "line_values", "wrinkle_profile"]
