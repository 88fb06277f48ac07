"""The picture of one life test (seed 004 Sec. 4.1): sound level against travel with the detected rise,
drop and failure travel, and the accelerometer spectrogram against travel (full band with the machine's band, and a
zoom on the kinematic defect frequencies, the raceway frequency and its harmonics marked). matplotlib (Agg) is
imported on use."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from guide_health.io.outputs.files import save_figure
from guide_health.models.rolling.vibration import welch_psd

ZOOM_HARMONICS = 4


def _spectrogram(blocks, fs: float, segment: int) -> tuple[np.ndarray, np.ndarray]:
    rows = []
    f = None
    for x in blocks:
        f, psd = welch_psd(np.asarray(x, dtype=float), fs, segment=min(segment, len(x)))
        rows.append(10.0 * np.log10(np.maximum(psd, 1e-20)))
    return f, np.array(rows)


def plot_life_test(path: str | Path, data: dict, summary: dict, p: Any, title: str = "") -> Path:
    """Write the PNG of one life test. ``data``: read_life_test_bag's dict; ``summary``: the detector's summary
    (failure/rise/drop travels, defect frequencies); ``p``: the vibration_monitor
    parameters (VibrationMonitorParams: speed, sample rate)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    v = p.carriage_speed_m_s
    fs = float(data.get("sample_rate_hz") or p.sample_rate_hz)
    starts = [int(a[0]) for a in (data["block_t_ns"], data["level_t_ns"]) if len(a)]
    t0 = min(starts)
    block_km = v * (np.asarray(data["block_t_ns"], dtype=float) - t0) / 1e12
    level_km = v * (np.asarray(data["level_t_ns"], dtype=float) - t0) / 1e12
    fig, axes = plt.subplots(3, 1, figsize=(9, 10), sharex=True, gridspec_kw={"height_ratios": [1, 1.2, 1.2]})
    ax = axes[0]
    ax.plot(level_km, data["level_db"], ".", ms=2, color="0.4", label="sound level")
    marks = (("failure_travel_km", "tab:red", "abnormal band (failure)"), ("noise_rise_km", "tab:orange", "noise rise"),
             ("noise_drop_km", "tab:purple", "noise drop (loosening)"))
    for key, color, label in marks:
        if summary.get(key) is not None:
            for a in axes:
                a.axvline(summary[key], color=color, lw=1.0, ls="--", label=label if a is ax else None)
    ax.set_ylabel("sound level [dB]")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(title or "life test: noise and vibration against travel (seed 004)")
    f, spec = _spectrogram(data["blocks"], fs, int(p.welch_segment))
    axes[1].pcolormesh(block_km, f / 1e3, spec.T, shading="nearest", cmap="viridis")
    axes[1].set_ylabel("frequency [kHz]")
    axes[1].set_title("spectrogram (Welch per block): the machine band and broadband wear", fontsize=9)
    defects = summary.get("defect_frequencies_hz") or {}
    f_race = defects.get("raceway_hz")
    top = (ZOOM_HARMONICS + 1) * f_race if f_race else fs / 2
    fz, specz = _spectrogram(data["blocks"], fs, len(data["blocks"][0]))
    keep = fz <= top
    axes[2].pcolormesh(block_km, fz[keep], specz[:, keep].T, shading="nearest", cmap="viridis")
    if f_race:
        for k in range(1, ZOOM_HARMONICS + 1):
            axes[2].axhline(k * f_race, color="w", lw=0.6, ls=":")
        axes[2].text(block_km[0], f_race, f" raceway defect {f_race:.1f} Hz (x1..{ZOOM_HARMONICS})", color="w",
                     va="bottom", fontsize=8)
    named = summary.get("defect")
    axes[2].set_title(f"zoom on the kinematic defect frequencies; named tone: {named or 'none'}", fontsize=9)
    axes[2].set_ylabel("frequency [Hz]")
    axes[2].set_xlabel("travel [km]")
    fig.tight_layout()
    path = Path(path)
    try:
        save_figure(fig, path, dpi=90)          # 0640, never through a symlink
    finally:
        plt.close(fig)
    return path
