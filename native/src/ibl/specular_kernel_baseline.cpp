// The specular kernel and the row kernels built for baseline (flags in native/CMakeLists.txt).
#define IBLBAKE_KERNEL_NAME sums_baseline
#include "specular_kernel_impl.h"
#define IBLBAKE_ISA_SUFFIX baseline
#include "row_kernels_impl.h"
