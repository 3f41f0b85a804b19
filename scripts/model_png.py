"""Draw model.png, the icon an importer shows for the FMU (FMI 2.0 section 2.4): a simple
schematic of each actuator, 256 x 256 pixels, byte-reproducible (no time stamp or version in
the PNG metadata, matplotlib's bundled font).

usage: python scripts/model_png.py MODEL_IDENTIFIER OUT.png"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

INK, OIL, STEEL = "#1f2d3d", "#d9822b", "#8a9bb0"


def spring(ax, x0, x1, y, turns=5, amp=0.025):
    x = np.linspace(x0, x1, 4 * turns + 1)
    yy = y + amp * np.array([0, 1, 0, -1] * turns + [0])
    ax.plot(x, yy, color=INK, lw=1.5)


def hydraulic_joint(ax):
    """Two cylinders (agonist, antagonist), series springs, cables around the pulley, the link."""
    for y, flip in ((0.72, 1), (0.28, -1)):
        ax.add_patch(Rectangle((0.04, y - 0.08), 0.3, 0.16, fc=OIL, ec=INK, lw=1.5))
        ax.add_patch(Rectangle((0.2, y - 0.07), 0.03, 0.14, fc=STEEL, ec=INK))
        ax.plot([0.23, 0.42], [y, y], color=INK, lw=2)
        spring(ax, 0.42, 0.58, y)
        ax.plot([0.58, 0.7], [y, 0.5 + flip * 0.12], color=INK, lw=1.5)
    ax.add_patch(Circle((0.72, 0.5), 0.12, fc=STEEL, ec=INK, lw=1.5))
    ax.plot([0.72, 0.95], [0.5, 0.86], color=INK, lw=4, solid_capstyle="round")
    ax.add_patch(Circle((0.95, 0.86), 0.04, fc=INK))
    ax.text(0.5, 0.04, "HydraulicJoint", ha="center", fontsize=13, color=INK)


def twisted_string(ax):
    """Motor and gearhead on top, the twisted strings down to the load, the return spring."""
    ax.add_patch(Rectangle((0.38, 0.8), 0.24, 0.14, fc=STEEL, ec=INK, lw=1.5))
    ax.add_patch(Rectangle((0.43, 0.72), 0.14, 0.08, fc=INK))
    y = np.linspace(0.32, 0.72, 200)
    for phase in (0, np.pi / 2, np.pi, 3 * np.pi / 2):
        ax.plot(0.5 + 0.03 * np.sin(40 * y + phase), y, color=OIL, lw=1.5)
    ax.add_patch(Rectangle((0.36, 0.18), 0.28, 0.14, fc=STEEL, ec=INK, lw=1.5))
    x = 0.8 + 0.025 * np.array([0, 1, -1] * 5 + [0])
    ax.plot(x, np.linspace(0.92, 0.25, len(x)), color=INK, lw=1.5)
    ax.plot([0.64, 0.8], [0.25, 0.25], color=INK, lw=1.5)
    ax.text(0.5, 0.04, "TwistedString", ha="center", fontsize=13, color=INK)


def generic(ax, name):
    ax.add_patch(Rectangle((0.2, 0.3), 0.6, 0.4, fc=STEEL, ec=INK, lw=1.5))
    ax.text(0.5, 0.5, name, ha="center", va="center", fontsize=12, color=INK)


def main(identifier, out):
    fig = plt.figure(figsize=(2.56, 2.56), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.axis("off")
    {"HydraulicJoint": hydraulic_joint, "TwistedString": twisted_string}.get(
        identifier, lambda a: generic(a, identifier))(ax)
    fig.savefig(out, dpi=100, metadata={"Software": None}, facecolor="white")


if __name__ == "__main__":
    main(*sys.argv[1:])
