// The batched tracer's kernel compiled with -mavx2 -mfma (CMakeLists.txt); run only where the
// processor has AVX2 and FMA.
#define PORTHOLE_OPTICS_ISA_NS isa_avx2
#define PORTHOLE_BATCH_KERNELS KernelsAvx2
#define PORTHOLE_BATCH_LANE std::int16_t  // interleaving: batch_kernel.inc
#include "porthole/optics/batch_kernel.inc"
