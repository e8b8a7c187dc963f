// Quadrature rules. No I/O.
#pragma once
#include <vector>

namespace iblbake {

struct QuadratureRule {
    std::vector<double> nodes, weights;  // on the interval the rule was made for
};

// n-point Gauss-Legendre rule on [a, b] (Golub-Welsch free: Newton on P_n,
// exact for polynomials of degree 2n-1).
QuadratureRule gauss_legendre(int n, double a = -1.0, double b = 1.0);

}  // namespace iblbake
