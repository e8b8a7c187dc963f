#include "iblbake/math/spline.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace iblbake {

std::vector<double> not_a_knot_matrix(int n) {
    if (n < 4) throw std::invalid_argument("not_a_knot_matrix: need at least 4 nodes");
    // A m = R y with unit spacing: interior rows m[i-1]/6 + 2m[i]/3 + m[i+1]/6
    // = y[i-1] - 2y[i] + y[i+1]; the ends say the third derivative is
    // continuous at nodes 1 and n-2: m[0] - 2m[1] + m[2] = 0 (and mirrored).
    const size_t N = size_t(n);
    std::vector<double> a(N * N, 0.0), r(N * N, 0.0);
    auto A = [&](int i, int j) -> double& { return a[size_t(i) * N + j]; };
    auto R = [&](int i, int j) -> double& { return r[size_t(i) * N + j]; };
    A(0, 0) = 1.0; A(0, 1) = -2.0; A(0, 2) = 1.0;
    A(n - 1, n - 3) = 1.0; A(n - 1, n - 2) = -2.0; A(n - 1, n - 1) = 1.0;
    for (int i = 1; i + 1 < n; ++i) {
        A(i, i - 1) = 1.0 / 6.0; A(i, i) = 2.0 / 3.0; A(i, i + 1) = 1.0 / 6.0;
        R(i, i - 1) = 1.0; R(i, i) = -2.0; R(i, i + 1) = 1.0;
    }
    // Gauss-Jordan with partial pivoting on [A | R]: S = A^-1 R. Done once per
    // node count (n is small), so clarity beats a banded solver here.
    for (int c = 0; c < n; ++c) {
        int p = c;
        for (int i = c + 1; i < n; ++i)
            if (std::fabs(A(i, c)) > std::fabs(A(p, c))) p = i;
        if (p != c)
            for (int j = 0; j < n; ++j) {
                std::swap(A(c, j), A(p, j));
                std::swap(R(c, j), R(p, j));
            }
        const double inv = 1.0 / A(c, c);
        for (int j = 0; j < n; ++j) {
            A(c, j) *= inv;
            R(c, j) *= inv;
        }
        for (int i = 0; i < n; ++i) {
            if (i == c || A(i, c) == 0.0) continue;
            const double f = A(i, c);
            for (int j = 0; j < n; ++j) {
                A(i, j) -= f * A(c, j);
                R(i, j) -= f * R(c, j);
            }
        }
    }
    return r;
}

double spline_at(const double* y, const double* m, int n, double t) {
    t = std::clamp(t, 0.0, double(n - 1));
    const int k = std::min(int(t), n - 2);
    const double b = t - k, a = 1.0 - b;
    return a * y[k] + b * y[k + 1] + ((a * a * a - a) * m[k] + (b * b * b - b) * m[k + 1]) / 6.0;
}

}  // namespace iblbake
