// The batched tracer's kernel compiled with -mavx512f -mavx512vl -mavx512dq -mavx512bw -mavx2
// -mfma (CMakeLists.txt); run only where the processor has them all.
#define PORTHOLE_OPTICS_ISA_NS isa_avx512
#define PORTHOLE_BATCH_KERNELS KernelsAvx512
#define PORTHOLE_BATCH_LANE std::int32_t  // interleaving: batch_kernel.inc
#include "porthole/optics/batch_kernel.inc"
