#!/usr/bin/env python3
"""Reduces measured spectral complex indices of metals to the RGB `eta`, `k` of rift's named metals.

Source data: the spectral n, k tables that ship with Mitsuba 3 (`mitsuba/data/ior/*.spd`, from
the luxpop optical-constants database: gold, silver and copper after Johnson & Christy's and
Palik's measurements, aluminium after Rakic). Colour science: CIE 1931 2° matching functions and
illuminant D65, also from Mitsuba's tables, with the linear Rec.709/sRGB primaries.

Method: the exact spectral Fresnel reflectance R(λ, θ) at 64 incidence angles is turned into a
linear Rec.709 colour under D65 (so a perfect reflector is (1, 1, 1)); then per channel the one
(η, k) whose Fresnel curve best fits that channel's curve is found by least squares weighted by
cos θ (how much each angle matters under uniform light). Fitting the reflectance rather than
averaging η and k over the channel keeps the colour at normal incidence and at grazing angles both right: the
printed table gives the colour at 0° and the worst error over angles.

    pip install mitsuba numpy
    python3 tools/metals_rgb.py   # prints the table for render/src/scene/metals.rs
"""
from pathlib import Path

import numpy as np

METALS = {"gold": "Au", "silver": "Ag", "copper": "Cu", "aluminium": "Al"}


def load_spd(path):
    rows = [line.split() for line in Path(path).read_text().splitlines()
            if line.strip() and not line.lstrip().startswith("#")]
    data = np.array([[float(a), float(b)] for a, b in rows])
    return data[:, 0], data[:, 1]


def fresnel_conductor(cos, eta, k):
    """Exact unpolarised reflectance, complex arithmetic (independent of rift's closed form)."""
    n = eta + 1j * k
    sin2 = 1.0 - cos ** 2
    cos_t = np.sqrt(1.0 - sin2 / n ** 2 + 0j)
    rs = (cos - n * cos_t) / (cos + n * cos_t)
    rp = (n * cos - cos_t) / (n * cos + cos_t)
    return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)


def colour_tables():
    import mitsuba as mi

    mi.set_variant("scalar_spectral")
    lam = np.arange(360.0, 831.0, 1.0)
    xyz = np.array([list(mi.cie1931_xyz(float(l))) for l in lam])
    d65 = np.array([float(mi.cie_d65(float(l))) for l in lam])
    to_rgb = np.array([[3.240479, -1.537150, -0.498535],
                       [-0.969256, 1.875991, 0.041556],
                       [0.055648, -0.204043, 1.057311]])
    weights = (xyz * d65[:, None]) @ to_rgb.T
    weights /= weights.sum(axis=0)  # a flat reflectance of 1 is (1, 1, 1)
    return lam, weights, Path(mi.__file__).parent / "data" / "ior"


def desaturate_into_gamut(rgb):
    """Gold's red lies outside Rec.709: above 1, which a metal cannot reflect. Each angle's
    colour is moved towards its own luminance just far enough to bring every channel to ≤ 1."""
    y = np.array([0.2126, 0.7152, 0.0722]) @ rgb
    over = rgb.max(axis=0)
    s = np.where(over > 1.0, (1.0 - y) / np.maximum(over - y, 1e-9), 1.0)
    return y + s * (rgb - y)


def fit_channel(cos, target, w):
    """Least-squares (η, k) for one channel's reflectance curve: a coarse log grid, then refined."""
    best = None
    eta_range, k_range = (np.log(0.02), np.log(5.0)), (np.log(0.05), np.log(12.0))
    for _ in range(6):
        etas = np.exp(np.linspace(*eta_range, 60))
        ks = np.exp(np.linspace(*k_range, 60))
        e, kk = np.meshgrid(etas, ks, indexing="ij")
        r = fresnel_conductor(cos[None, None, :], e[..., None], kk[..., None])
        err = ((r - target) ** 2 * w).sum(-1)
        i, j = np.unravel_index(np.argmin(err), err.shape)
        best = (etas[i], ks[j])
        de = (eta_range[1] - eta_range[0]) / 20
        dk = (k_range[1] - k_range[0]) / 20
        eta_range = (np.log(best[0]) - de, np.log(best[0]) + de)
        k_range = (np.log(best[1]) - dk, np.log(best[1]) + dk)
    return best


def main():
    lam, weights, ior_dir = colour_tables()
    cos = np.linspace(1.0, 0.0, 64, endpoint=False)[::-1]
    w = cos / cos.sum()
    print("// name: eta (R, G, B), k (R, G, B); normal-incidence colour; worst error over angles")
    for name, symbol in METALS.items():
        le, eta = load_spd(ior_dir / f"{symbol}.eta.spd")
        lk, k = load_spd(ior_dir / f"{symbol}.k.spd")
        # Wavelengths in the files are in Ångström when above 1000.
        le, lk = [x / 10.0 if x.max() > 1000 else x for x in (le, lk)]
        eta_l, k_l = np.interp(lam, le, eta), np.interp(lam, lk, k)
        spectral = fresnel_conductor(cos[None, :], eta_l[:, None], k_l[:, None])
        rgb = desaturate_into_gamut(weights.T @ spectral)  # 3 x angles
        fits = [fit_channel(cos, rgb[c], w) for c in range(3)]
        fitted = np.array([fresnel_conductor(cos, e, kk) for e, kk in fits])
        worst = np.abs(fitted - rgb).max()
        e = ", ".join(f"{f[0]:.4f}" for f in fits)
        kk = ", ".join(f"{f[1]:.4f}" for f in fits)
        print(f'("{name}", [{e}], [{kk}]),  // F0 {np.round(rgb[:, -1], 4)}, worst {worst:.4f}')


if __name__ == "__main__":
    main()
