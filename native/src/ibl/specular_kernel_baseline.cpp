// The specular kernel built for baseline (flags in native/CMakeLists.txt).
#define IBLBAKE_KERNEL_NAME sums_baseline
#include "specular_kernel_impl.h"
