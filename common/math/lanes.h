#pragma once
// Loops over the lanes of a packet (render/integrator.h): arrays over the kPacketWidth lanes
// (structure of arrays) and one formula applied to every lane, which the compiler turns into
// vector instructions.
//
// Such loops are compiled three times, for AVX-512, AVX2 and the x86-64 baseline, and the
// machine picks one when the program starts (GCC function multiversioning). Every version does
// the same IEEE operations on each lane in the same order (floating-point contraction is off
// for the whole project, CMakeLists.txt), so a lane's bits do not depend on the machine's vector
// width (tests/render/packet_integrator_test.cpp compares them with the one-ray tracer).
//
// A lane loop's body must stay free of calls and of branches the compiler cannot turn into
// selects; build with -fopt-info-vec to see which loops vectorise (docs/performance.md).

namespace lensfarm {
// Rays travel in packets of up to 16 (render/integrator.h): Embree's 16-wide kernels trace them
// together, which is what AVX-512 machines are fastest at, and the lane loops work on 16 lanes.
inline constexpr int kPacketWidth = 16;
}  // namespace lensfarm

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define LENSFARM_LANE_LOOPS __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define LENSFARM_LANE_LOOPS
#endif
