"""Colour-vision-deficiency simulation and sRGB transfer functions (numpy, no VTK).

Machado, Oliveira & Fernandes (2009) simulation matrices, as tabulated in steps of 0.1 of
severity in Machado's 2010 thesis (the 1.0 rows are docs/SCIENCE.md §9's). Severity s between
the tabulated values is interpolated linearly between the bracketing tables:
M(s) = M_k + 10 (s - k/10) (M_{k+1} - M_k), k = floor(10 s) (docs/SCIENCE.md §9 lists the
library bugs this avoids). Matrices apply to linear RGB; images are decoded from sRGB,
transformed, clipped and re-encoded. Achromatopsia uses the Rec. 709 luminance Y.
"""

from __future__ import annotations

import numpy as np

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError

# fmt: off
_TABLES = {
    "protan": [
        [[1.000000, 0.000000, -0.000000], [0.000000, 1.000000, 0.000000], [-0.000000, -0.000000, 1.000000]],  # noqa: E501
        [[0.856167, 0.182038, -0.038205], [0.029342, 0.955115, 0.015544], [-0.002880, -0.001563, 1.004443]],  # noqa: E501
        [[0.734766, 0.334872, -0.069637], [0.051840, 0.919198, 0.028963], [-0.004928, -0.004209, 1.009137]],  # noqa: E501
        [[0.630323, 0.465641, -0.095964], [0.069181, 0.890046, 0.040773], [-0.006308, -0.007724, 1.014032]],  # noqa: E501
        [[0.539009, 0.579343, -0.118352], [0.082546, 0.866121, 0.051332], [-0.007136, -0.011959, 1.019095]],  # noqa: E501
        [[0.458064, 0.679578, -0.137642], [0.092785, 0.846313, 0.060902], [-0.007494, -0.016807, 1.024301]],  # noqa: E501
        [[0.385450, 0.769005, -0.154455], [0.100526, 0.829802, 0.069673], [-0.007442, -0.022190, 1.029632]],  # noqa: E501
        [[0.319627, 0.849633, -0.169261], [0.106241, 0.815969, 0.077790], [-0.007025, -0.028051, 1.035076]],  # noqa: E501
        [[0.259411, 0.923008, -0.182420], [0.110296, 0.804340, 0.085364], [-0.006276, -0.034346, 1.040622]],  # noqa: E501
        [[0.203876, 0.990338, -0.194214], [0.112975, 0.794542, 0.092483], [-0.005222, -0.041043, 1.046265]],  # noqa: E501
        [[0.152286, 1.052583, -0.204868], [0.114503, 0.786281, 0.099216], [-0.003882, -0.048116, 1.051998]],  # noqa: E501
    ],
    "deutan": [
        [[1.000000, 0.000000, -0.000000], [0.000000, 1.000000, 0.000000], [-0.000000, -0.000000, 1.000000]],  # noqa: E501
        [[0.866435, 0.177704, -0.044139], [0.049567, 0.939063, 0.011370], [-0.003453, 0.007233, 0.996220]],  # noqa: E501
        [[0.760729, 0.319078, -0.079807], [0.090568, 0.889315, 0.020117], [-0.006027, 0.013325, 0.992702]],  # noqa: E501
        [[0.675425, 0.433850, -0.109275], [0.125303, 0.847755, 0.026942], [-0.007950, 0.018572, 0.989378]],  # noqa: E501
        [[0.605511, 0.528560, -0.134071], [0.155318, 0.812366, 0.032316], [-0.009376, 0.023176, 0.986200]],  # noqa: E501
        [[0.547494, 0.607765, -0.155259], [0.181692, 0.781742, 0.036566], [-0.010410, 0.027275, 0.983136]],  # noqa: E501
        [[0.498864, 0.674741, -0.173604], [0.205199, 0.754872, 0.039929], [-0.011131, 0.030969, 0.980162]],  # noqa: E501
        [[0.457771, 0.731899, -0.189670], [0.226409, 0.731012, 0.042579], [-0.011595, 0.034333, 0.977261]],  # noqa: E501
        [[0.422823, 0.781057, -0.203881], [0.245752, 0.709602, 0.044646], [-0.011843, 0.037423, 0.974421]],  # noqa: E501
        [[0.392952, 0.823610, -0.216562], [0.263559, 0.690210, 0.046232], [-0.011910, 0.040281, 0.971630]],  # noqa: E501
        [[0.367322, 0.860646, -0.227968], [0.280085, 0.672501, 0.047413], [-0.011820, 0.042940, 0.968881]],  # noqa: E501
    ],
    "tritan": [
        [[1.000000, 0.000000, -0.000000], [0.000000, 1.000000, 0.000000], [-0.000000, -0.000000, 1.000000]],  # noqa: E501
        [[0.926670, 0.092514, -0.019184], [0.021191, 0.964503, 0.014306], [0.008437, 0.054813, 0.936750]],  # noqa: E501
        [[0.895720, 0.133330, -0.029050], [0.029997, 0.945400, 0.024603], [0.013027, 0.104707, 0.882266]],  # noqa: E501
        [[0.905871, 0.127791, -0.033662], [0.026856, 0.941251, 0.031893], [0.013410, 0.148296, 0.838294]],  # noqa: E501
        [[0.948035, 0.089490, -0.037526], [0.014364, 0.946792, 0.038844], [0.010853, 0.193991, 0.795156]],  # noqa: E501
        [[1.017277, 0.027029, -0.044306], [-0.006113, 0.958479, 0.047634], [0.006379, 0.248708, 0.744913]],  # noqa: E501
        [[1.104996, -0.046633, -0.058363], [-0.032137, 0.971635, 0.060503], [0.001336, 0.317922, 0.680742]],  # noqa: E501
        [[1.193214, -0.109812, -0.083402], [-0.058496, 0.979410, 0.079086], [-0.002346, 0.403492, 0.598854]],  # noqa: E501
        [[1.257728, -0.139648, -0.118081], [-0.078003, 0.975409, 0.102594], [-0.003316, 0.501214, 0.502102]],  # noqa: E501
        [[1.278864, -0.125333, -0.153531], [-0.084748, 0.957674, 0.127074], [-0.000989, 0.601151, 0.399838]],  # noqa: E501
        [[1.255528, -0.076749, -0.178779], [-0.078411, 0.930809, 0.147602], [0.004733, 0.691367, 0.303900]],  # noqa: E501
    ],
}
# fmt: on
MACHADO = {k: np.array(v) for k, v in _TABLES.items()}
CVD_KINDS = ("protan", "deutan", "tritan", "achromat")
REC709_Y = np.array([0.2126, 0.7152, 0.0722])


def machado_matrix(kind: str, severity: float) -> np.ndarray:
    """(3, 3) simulation matrix for linear RGB, severity in [0, 1]."""
    if kind not in MACHADO:
        raise SpecError("cvd", f"must be one of {CVD_KINDS}, got {kind!r}")
    s = check_range("cvd_severity", severity, 0.0, 1.0)
    k = min(int(np.floor(10 * s)), 9)
    t = 10 * s - k
    tab = MACHADO[kind]
    return tab[k] + t * (tab[k + 1] - tab[k])


def srgb_to_linear(c):
    c = np.asarray(c, float)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c):
    c = np.clip(np.asarray(c, float), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


#: Linear light of each sRGB code value (float32 table: decoding is a look-up).
_DECODE_U8 = srgb_to_linear(np.arange(256) / 255.0).astype(np.float32)


def decode_srgb(codes) -> np.ndarray:
    """uint8 sRGB codes (any shape) -> float32 linear light in [0, 1] (a table look-up;
    :func:`encode_srgb` inverts it exactly on every code)."""
    return _DECODE_U8[np.asarray(codes, np.uint8)]


#: The linear light where each sRGB code k (1..255) begins: the value that encodes to
#: k - 0.5, so that encoding is a search among 255 edges instead of a power per value.
_ENCODE_EDGES = srgb_to_linear((np.arange(1, 256) - 0.5) / 255.0)


def encode_srgb(linear) -> np.ndarray:
    """Linear light (any shape, clipped to [0, 1]) -> uint8 sRGB codes: the nearest code of
    :func:`linear_to_srgb` (IEC 61966-2-1), found among the codes' edges in linear light
    (the same codes as rounding the formula, tested; a few times faster); NaN -> 0."""
    x = np.asarray(linear)
    codes = np.searchsorted(_ENCODE_EDGES, x, side="right").astype(np.uint8)
    if x.dtype.kind == "f":
        codes[np.isnan(x)] = 0
    return codes


def cvd_linear(lin: np.ndarray, kind: str, severity: float = 1.0) -> np.ndarray:
    """A colour-vision deficiency applied to linear RGB (..., 3): Machado 2009's matrix, or
    Rec. 709 luminance mixed in by ``severity`` for ``"achromat"``; clipped to [0, 1]."""
    if kind == "achromat":
        check_range("cvd_severity", severity, 0.0, 1.0)
        y = lin @ REC709_Y
        out = (1 - severity) * lin + severity * y[..., None]
    else:
        out = lin @ machado_matrix(kind, severity).T
    return np.clip(out, 0.0, 1.0)


def simulate_cvd(image_u8: np.ndarray, kind: str, severity: float = 1.0) -> np.ndarray:
    """Simulate a colour-vision deficiency on an sRGB uint8 image (h, w, 3): decode to linear
    RGB, :func:`cvd_linear`, re-encode."""
    lin = srgb_to_linear(np.asarray(image_u8)[..., :3] / 255.0)
    return encode_srgb(cvd_linear(lin, kind, severity))
