#!/usr/bin/python3
"""Bearing loads of a `morse rampup` file over the driving speed (one panel per bearing, F_x and
F_y, and the envelope |F|). usage: run/plot_rampup.py FILE.h5 OUT.png"""
import sys

import h5py
import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

f = h5py.File(sys.argv[1], "r")["/rampup"]
rpm = f["omega"][:] * 60 / (2 * np.pi)
F = f["bearing_force"][:]
names = f.attrs["bearings"]
names = (names.decode() if isinstance(names, bytes) else names).split(",")
nb = F.shape[1]
fig, ax = plt.subplots((nb + 1) // 2, 2, figsize=(11, 3.2 * ((nb + 1) // 2)), squeeze=False)
for b in range(nb):
    a = ax.flat[b]
    a.plot(rpm, F[:, b, 0], lw=0.5, label="F_x")
    a.plot(rpm, F[:, b, 1], lw=0.5, label="F_y")
    a.plot(rpm, np.hypot(F[:, b, 0], F[:, b, 1]), "k", lw=1, label="|F|")
    a.set_title("bearing %s" % names[b], fontsize=10)
    a.set_xlabel("driving speed [rpm]")
    a.set_ylabel("force on the housing [N]")
    a.grid(alpha=0.3)
ax.flat[0].legend(fontsize=8)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
print("wrote %s" % sys.argv[2])
