// The specular kernel built for avx2 (flags in native/CMakeLists.txt).
#define IBLBAKE_KERNEL_NAME sums_avx2
#include "specular_kernel_impl.h"
