# %% [markdown]
# # Speed against error, from Python
# Each technique variant of the engine is rendered on the bunny and compared with the Monte Carlo ground truth
# (the triangles); its shading time is plotted against its relative RMSE. Run as a script
# (`python python/examples/speed_vs_error.py [out.png]`) or cell by cell in a notebook (`# %%` cells).
# Needs matplotlib beside softshadows: `pip install ./python matplotlib`.

# %%
import sys
import time

import matplotlib

matplotlib.use("Agg")  # no display needed; drop this line in a notebook
import matplotlib.pyplot as plt
import numpy as np

import softshadows as ss

t0 = time.time()
scene = ss.load("bunny")
r = ss.Renderer(device=None)
print("device:", r.device, "| techniques:", ss.techniques())

# %% One image, linear float32 H×W×3, and where its GPU time went.
img = r.render(scene, technique="isg:patches=16", width=160, height=120)
print(img.shape, img.dtype, "mean radiance", float(img.mean()))
print({name: round(ms, 2) for name, ms in r.last_pass_times().items()})

# %% The table: every variant against one converged triangle reference (rows are dicts).
variants = ["isg:patches=4", "isg:patches=8", "isg:patches=16", "shexp:order=3", "shexp", "lobes:depth=2", "lobes"]
table = r.compare(scene, variants, width=80, height=60, visibility="triangles", frames=3, max_spp=1024)
for row in table:
    print(f"{row['technique']:>16}  {row['debiased_percent']:6.2f} %  {row['shade_ms']:8.2f} ms")

# %% Speed against error.
fig, ax = plt.subplots(figsize=(6, 4))
for row in table:
    family = row["technique"].split(":")[0]
    colour = {"isg": "tab:blue", "shexp": "tab:orange", "lobes": "tab:green"}[family]
    ax.scatter(row["shade_ms"], row["debiased_percent"], color=colour)
    ax.annotate(row["technique"], (row["shade_ms"], row["debiased_percent"]), fontsize=7,
                xytext=(4, 3), textcoords="offset points")
ax.set_xscale("log")
ax.set_xlabel("shade time, ms (llvmpipe: compare ratios, not ms)")
ax.set_ylabel("relative RMSE vs triangles, % (net of reference noise)")
spp = table[0]["reference_spp"]
ax.set_title(f"bunny 80×60, reference {spp} spp, {r.device}", fontsize=8)
ax.grid(True, which="both", alpha=0.3)
fig.tight_layout()
out = sys.argv[1] if len(sys.argv) > 1 else "speed_vs_error.png"
fig.savefig(out, dpi=120)
r.close()
print(f"wrote {out} in {time.time() - t0:.0f} s")
