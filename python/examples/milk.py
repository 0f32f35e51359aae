"""The tutorial's pipeline in twenty lines: milk's optical properties from its content
declaration, a plot of them, and a small render of the milk glass (scenes/milk-glass.toml).
Run from the repository root: python3 python/examples/milk.py [FAT_PERCENT]"""
import pathlib, sys
import numpy as np
import lucent

fat = float(sys.argv[1]) if len(sys.argv) > 1 else 3.5
m = lucent.milk(fat, wavelengths_nm=np.arange(400.0, 701.0, 25.0))
for l, s, a, g in zip(m.wavelength_nm, m.sigma_s_per_mm, m.sigma_a_per_mm, m.g):
    print(f"{l:5.0f} nm  σs {s:8.3f} mm⁻¹  σa {a:.2e} mm⁻¹  g {g:.3f}")
root = pathlib.Path(__file__).resolve().parents[2]
img = lucent.Scene.load(root / "scenes" / "milk-glass.toml").render(spp=16, width=160, integrator="volpath",
                                                                       progress=lambda n, t, s: print(f"\r{n}/{t} spp", end=""))
srgb = np.where(img <= 0.0031308, 12.92 * img, 1.055 * np.clip(img, 0, None) ** (1 / 2.4) - 0.055).clip(0, 1)
try:
    import matplotlib.pyplot as plt
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax.semilogy(m.wavelength_nm, m.sigma_s_per_mm, label="σs"); ax.semilogy(m.wavelength_nm, m.sigma_a_per_mm, label="σa")
    ax.set_xlabel("wavelength [nm]"); ax.set_ylabel("mm⁻¹"); ax.legend(); ax2.imshow(srgb); ax2.axis("off")
    fig.savefig("milk.png", dpi=100); print("\nwrote milk.png"); plt.show()
except ImportError:
    np.save("milk-glass.npy", img); print("\nmatplotlib not installed: wrote milk-glass.npy (linear sRGB)")
