"""Image metrics in linear RGB: PSNR, SSIM (scikit-image) and a blur-size proxy."""

from __future__ import annotations

import numpy as np

from eyelab.core.color import srgb_to_linear


def to_linear(img_u8):
    return srgb_to_linear(np.asarray(img_u8, float)[..., :3] / 255.0)


def psnr(a, b) -> float:
    """PSNR (dB) of linear-RGB images in [0, 1]; inf when identical."""
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def ssim(a, b) -> float:
    from skimage.metrics import structural_similarity

    win = min(7, min(a.shape[:2]) // 2 * 2 - 1)
    return float(structural_similarity(a, b, channel_axis=2, data_range=1.0, win_size=win))


def gradient_energy(lin) -> float:
    """Mean squared luminance gradient (1/px^2): for a fixed target it falls as the blur
    grows (~ 1 / blur^2 for blur larger than the target's detail)."""
    y = lin @ np.array([0.2126, 0.7152, 0.0722])
    gy, gx = np.gradient(y)
    return float(np.mean(gx**2 + gy**2))


def compare_images(test_u8, ref_u8) -> dict:
    """PSNR, SSIM and the relative blur-size error sqrt(G_ref / G_test) - 1 (G: gradient
    energy; 0 when the test image is exactly as sharp as the reference), in linear RGB."""
    a, b = to_linear(test_u8), to_linear(ref_u8)
    ga, gb = gradient_energy(a), gradient_energy(b)
    blur_err = float(np.sqrt(gb / ga) - 1.0) if ga > 0 and gb > 0 else 0.0
    return {"psnr_db": psnr(a, b), "ssim": ssim(a, b), "blur_size_error": blur_err}
