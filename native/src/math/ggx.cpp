#include "iblbake/math/ggx.h"

#include "iblbake/math/quadrature.h"

namespace iblbake::ggx {

double prefilter_normalizer(double alpha) {
    const double a2 = alpha * alpha;
    const double c = a2 - 1.0;
    if (std::fabs(c) > 0.05) {
        return 4.0 * (-1.0 / c + 2.0 * a2 / (c * c) * std::log(2.0 * a2 / (1.0 + a2)));
    }
    static const QuadratureRule unit = gauss_legendre(24, 0.0, 1.0);
    const double upper = 1.0 / (1.0 + a2);
    double sum = 0.0;
    for (size_t i = 0; i < unit.nodes.size(); ++i) {
        const double u = unit.nodes[i] * upper;
        sum += unit.weights[i] * upper * (1.0 - (a2 + 1.0) * u) / (1.0 + c * u);
    }
    return 4.0 * sum;
}

}  // namespace iblbake::ggx
