// The batched tracer's kernel compiled with the compiler's baseline flags (SSE2 on x86-64).
#define PORTHOLE_OPTICS_ISA_NS isa_baseline
#define PORTHOLE_BATCH_KERNELS KernelsSse2
#define PORTHOLE_BATCH_LANE std::int16_t  // interleaving: batch_kernel.inc
#include "porthole/optics/batch_kernel.inc"
