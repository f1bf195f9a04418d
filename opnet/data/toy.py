"""Smooth toy shapes made offline: a capsule "finger" and deformations of it.

The deformations mimic the two kinds of change the paper's operators separate:
:func:`bend` is a change of *pose* (nearly isometric away from the joint), and
:func:`bulge` a change of *local area*. All meshes of one resolution share their
faces, so they are in 1-1 correspondence.
"""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh

__all__ = ["capsule", "bend", "bulge", "finger_pair"]

# vertices around the capsule per preset: about 430, 1010 and 4000 vertices in all
RESOLUTIONS = {"quick": 16, "default": 24, "paper": 48}


def capsule(preset: str = "default", length: float = 2.0, radius: float = 0.25) -> Mesh:
    """A closed capsule along ``z`` with near-uniform triangles; ``preset`` sets the resolution.

    The surface of revolution of a stadium profile (two hemispherical caps joined by a
    cylinder of ``length``), sampled by rings equally spaced in arc length.
    """
    if preset not in RESOLUTIONS:
        raise ValueError(f"preset must be one of {list(RESOLUTIONS)}, got {preset!r}.")
    n_seg = RESOLUTIONS[preset]
    cap = 0.5 * np.pi * radius
    total = 2 * cap + length
    n_rings = int(round(total / (2 * np.pi * radius / n_seg)))
    s = np.linspace(0.0, total, n_rings + 1)[1:-1]  # arc length from the bottom pole, poles excluded
    lower, upper = s < cap, s > cap + length
    phi = np.where(lower, s / radius, np.where(upper, (total - s) / radius, 0.5 * np.pi))
    rho = radius * np.sin(phi)
    z = np.where(
        lower,
        -0.5 * length - radius * np.cos(phi),
        np.where(upper, 0.5 * length + radius * np.cos(phi), s - cap - 0.5 * length),
    )
    theta = 2 * np.pi * (np.arange(n_seg)[None, :] + 0.5 * (np.arange(len(s))[:, None] % 2)) / n_seg
    ring = np.stack(
        [rho[:, None] * np.cos(theta), rho[:, None] * np.sin(theta), np.broadcast_to(z[:, None], theta.shape)], -1
    )
    bottom, top = 0, 1 + ring.shape[0] * n_seg
    vertices = np.vstack([[0, 0, -0.5 * length - radius], ring.reshape(-1, 3), [0, 0, 0.5 * length + radius]])
    j = np.arange(n_seg)
    idx = 1 + np.arange(len(s))[:, None] * n_seg + j[None, :]  # (rings, n_seg)
    nxt = np.roll(idx, -1, axis=1)
    a, b, c, d = idx[:-1], nxt[:-1], idx[1:], nxt[1:]
    odd = (np.arange(len(s) - 1) % 2 == 1)[:, None]  # alternate rings are offset by half a step
    quads = np.concatenate(
        [
            np.where(odd[..., None], np.stack([a, d, c], -1), np.stack([a, b, c], -1)),
            np.where(odd[..., None], np.stack([a, b, d], -1), np.stack([b, d, c], -1)),
        ]
    ).reshape(-1, 3)
    caps = np.concatenate(
        [
            np.stack([np.full(n_seg, bottom), idx[0, (j + 1) % n_seg], idx[0]], -1),
            np.stack([np.full(n_seg, top), idx[-1], idx[-1, (j + 1) % n_seg]], -1),
        ]
    )
    return Mesh(vertices, np.vstack([quads, caps]))


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def bend(vertices: np.ndarray, angle: float, joint: float = 0.2, width: float = 1.2) -> np.ndarray:
    """Bend the part above ``z = joint`` by ``angle`` (radians) about the ``x`` axis through the joint.

    The rotation angle ramps up smoothly over ``[joint − width/2, joint + width/2]``, like an elbow.
    """
    v = np.asarray(vertices, dtype=np.float64)
    theta = angle * _smoothstep((v[:, 2] - joint) / width + 0.5)
    c, s = np.cos(theta), np.sin(theta)
    y, z = v[:, 1], v[:, 2] - joint
    return np.stack([v[:, 0], c * y - s * z, s * y + c * z + joint], axis=1)


def bulge(vertices: np.ndarray, amount: float, center: float = -0.6, width: float = 0.3) -> np.ndarray:
    """Inflate the capsule radially around height ``center`` by a relative ``amount`` (0.3 = 30 %)."""
    v = np.asarray(vertices, dtype=np.float64)
    scale = 1 + amount * np.exp(-(((v[:, 2] - center) / width) ** 2))
    return v * np.stack([scale, scale, np.ones_like(scale)], axis=1)


def finger_pair(preset: str = "default") -> tuple[Mesh, Mesh]:
    """A base finger folded by 120° and a target straightened (bent by −10°) and inflated by 50 % near the bottom.

    Straightening moves the tip away from the rest of the shape (distances grow, as when
    a person raises an arm in the paper's figure), while the bulge changes local area.
    """
    straight = capsule(preset)
    base = straight.with_vertices(bend(straight.vertices, np.deg2rad(120)))
    target = straight.with_vertices(bend(bulge(straight.vertices, 0.5), np.deg2rad(-10)))
    return base, target
