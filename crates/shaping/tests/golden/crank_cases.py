"""Regenerates the slider-crank golden tables (docs/shaping.md, "Derivation: slider-crank
kinematics", eqs. (K1)-(K5)) with Python's math module only; prints the CSV rows to compare."""
import math

def row(R, L, rpm, th_deg):
    th = math.radians(th_deg)
    w = 2 * math.pi * rpm / 60
    lam = R / L
    alpha = math.asin(lam * math.sin(th))
    H = math.sqrt(L * L - R * R * math.sin(th) ** 2) - R * math.cos(th)
    Z = H - (L - R)
    dz = R * math.sin(th - alpha) / math.cos(alpha)
    d2z = R * math.cos(th) - R * R * (L * L * math.cos(2 * th) + R * R * math.sin(th) ** 4) / (
        L * L - R * R * math.sin(th) ** 2) ** 1.5
    return math.degrees(alpha), H, Z, w * dz, w * w * d2z

for t in [0, 30, 45, 60, 90, 120, 150, 180, 270]:
    a, H, Z, v, acc = row(25, 200, 300, t)
    print(f"{t},{a:.6f},{H:.6f},{Z:.6f},{v:.5f},{acc:.2f}")
for t in [30, 60, 90, 120, 150]:
    a, H, Z, v, acc = row(10, 100, 600, t)
    print(f"{t},{H:.6f},{v:.5f}")
