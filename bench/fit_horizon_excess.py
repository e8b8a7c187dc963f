"""The coefficients of irradiance.cpp's horizon_excess (kExcess).

H(x) = phi(x) - x Phi(-x), phi and Phi the standard normal density and
distribution: a hat's E[max(0, X)] - max(0, mu) is sigma H(|mu| / sigma) for
X Gaussian of mean mu and deviation sigma. On [0, 5] (the hot points within
5 sigma of a texel's horizon) in eight intervals of width 0.625, each as a
polynomial of degree 12 in t = (x - centre) / 0.3125, within 3e-17 of H
(Chebyshev fits by mpmath at 40 digits). Prints the C++ table.

    /usr/bin/python3 bench/fit_horizon_excess.py
"""
import mpmath as mp

mp.mp.dps = 40
INTERVALS, WIDTH, COEFFS = 8, 0.625, 13


def excess(x):
    return mp.npdf(x) - x * mp.ncdf(-x)


def main():
    half = WIDTH / 2
    print(f"constexpr int kExcessIntervals = {INTERVALS}, kExcessCoeffs = {COEFFS};")
    print("constexpr double kExcess[kExcessIntervals][kExcessCoeffs] = {")
    worst = 0
    for i in range(INTERVALS):
        centre = half + i * WIDTH
        poly, err = mp.chebyfit(lambda t, c=centre: excess(c + half * t), [-1, 1], COEFFS, error=True)
        worst = max(worst, err)
        coefs = list(reversed(poly))  # t^0 first
        print("    {" + ", ".join(mp.nstr(c, 17, min_fixed=1, max_fixed=0) for c in coefs) + "},")
    print("};")
    print(f"// worst fit error {mp.nstr(worst, 3)}")


if __name__ == "__main__":
    main()
