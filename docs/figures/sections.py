"""Draw docs/figures/sections.png: the Poincaré sections of configs/kovalevskaya.toml and
configs/chaotic_top.toml (needs matplotlib: pip install 'rotlab[plots]').  Run from the project root."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import rotlab  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
for ax, name, title in zip(axes, ["kovalevskaya", "chaotic_top"], ["Kovalevskaya top (integrable)", "asymmetric heavy top (chaotic)"]):
    section = rotlab.simulate(ROOT / "configs" / f"{name}.toml").events["section"]
    ax.plot(section.values[:, 0], section.values[:, 1], ".", ms=2.5)
    ax.set(title=f"{title}: {section.count} returns", xlabel="ω_x (rad/s, body)", ylabel="ω_y (rad/s, body)")
    ax.grid(alpha=0.3)
fig.suptitle("Poincaré sections at ω_z = 0 (rising), 600 s")
fig.savefig(ROOT / "docs" / "figures" / "sections.png", dpi=90)
