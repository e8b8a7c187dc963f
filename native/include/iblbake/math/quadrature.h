// Quadrature rules and low-discrepancy points. No I/O.
#pragma once
#include <cstdint>
#include <vector>

namespace iblbake {

struct QuadratureRule {
    std::vector<double> nodes, weights;  // on the interval the rule was made for
};

// n-point Gauss-Legendre rule on [a, b] (Golub-Welsch free: Newton on P_n,
// exact for polynomials of degree 2n-1).
QuadratureRule gauss_legendre(int n, double a = -1.0, double b = 1.0);

// Van der Corpus radical inverse in base 2 and the Hammersley point i of n
// (the seeds' sequence, kept for the baselines).
inline double radical_inverse_base2(uint32_t bits) {
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return double(bits) * 2.3283064365386963e-10;
}

}  // namespace iblbake
