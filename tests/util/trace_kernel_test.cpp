// Embree's kernels by the bits they give (util/trace_kernel.h): what a machine runs, what an expert's
// LENSFARM_EMBREE_CONFIG caps it to, the configuration string Embree is given, and the kernel a farm
// pins for a job from what its workers run.
#include "common/util/trace_kernel.h"

#include <gtest/gtest.h>

#include <string>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

struct EmbreeConfig : test::ScopedEnv {
  explicit EmbreeConfig(const char* value) : test::ScopedEnv("LENSFARM_EMBREE_CONFIG", value) {}
};

TEST(TraceKernel, NamesRoundTripAndOthersAreRefused) {
  for (const std::string& name : kernelNames()) {
    const auto k = kernelNamed(name);
    ASSERT_TRUE(k) << name;
    EXPECT_EQ(kernelName(*k), name);
  }
  EXPECT_FALSE(kernelNamed("avx512skx"));
  EXPECT_FALSE(kernelNamed(""));
}

TEST(TraceKernel, AnExpertsIsaCapsTheMachinesKernelsAndIsReplacedInTheDeviceConfig) {
  {
    EmbreeConfig unset(nullptr);
    const auto all = machineKernels();
    ASSERT_FALSE(all.empty());
#if defined(__x86_64__)
    EXPECT_EQ(all.front(), TraceKernel::kSse2) << "every x86-64 CPU runs SSE2";
#endif
    EXPECT_EQ(machineBestKernel(), all.back());
    EXPECT_EQ(embreeDeviceConfig(TraceKernel::kAvx2), "isa=avx2");
  }
#if defined(__x86_64__)
  {
    EmbreeConfig capped("threads=2, isa=sse2");
    EXPECT_EQ(machineKernels(), std::vector<TraceKernel>{TraceKernel::kSse2});
    EXPECT_EQ(embreeDeviceConfig(TraceKernel::kSse2), "threads=2,isa=sse2") << "its other settings are kept";
  }
  {
    EmbreeConfig avx("isa=avx");  // Embree's avx gives sse2's bits
    EXPECT_EQ(machineBestKernel(), TraceKernel::kSse2);
  }
#endif
}

TEST(TraceKernel, AJobPinsTheWidestKernelEveryConnectedWorkerRuns) {
  const std::vector<std::string> wide = {"sse2", "avx2", "avx512"}, avx2 = {"sse2", "avx2"}, old = {"sse2"};
  EXPECT_EQ(commonKernel({wide, wide}, wide), "avx512");
  EXPECT_EQ(commonKernel({wide, avx2}, wide), "avx2");
  EXPECT_EQ(commonKernel({wide, avx2, old}, avx2), "sse2");
  EXPECT_EQ(commonKernel({wide, {}}, wide), "avx512") << "a worker that said nothing constrains nothing";
  EXPECT_EQ(commonKernel({wide, {"neon"}}, wide), "avx512") << "none shared: the leased worker's widest";
  EXPECT_EQ(commonKernel({avx2}, {}), "avx2") << "a leased worker that said nothing gets what the others run";
  EXPECT_EQ(commonKernel({{}, {}}, {}), "") << "nobody said: not pinned";
  EXPECT_EQ(commonKernel({wide}, {"bogus", "avx2"}), "avx2") << "unknown names are ignored";
  EXPECT_TRUE(runsKernel(avx2, "avx2"));
  EXPECT_FALSE(runsKernel(avx2, "avx512"));
  EXPECT_TRUE(runsKernel({}, "avx512")) << "a worker that did not say is trusted";
  EXPECT_TRUE(runsKernel(old, "")) << "a job not pinned yet";
}

}  // namespace
}  // namespace lensfarm
