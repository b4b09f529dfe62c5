#pragma once
// What a renderer binary is, beside its version (util/version.h): the compiler, build type and
// the libraries whose arithmetic reaches the image (Embree's traversal, glibc's libm). Two
// workers of one version and one build identity give the same bits for the same kernel
// (util/trace_kernel.h); a farm's audit names a difference in either before it calls a worker
// wrong (docs/farm.md "Mixed machines"), and an EXR lists the builds that rendered it.
#include <string>

namespace lensfarm {

// "gcc 12.2.0 Release, Embree 3.13.5, glibc 2.36, x86_64": fixed for the process.
const std::string& buildIdentity();

// The CPU's model name (/proc/cpuinfo), for people: "AMD EPYC 7B13"; empty when unknown.
const std::string& cpuModel();

}  // namespace lensfarm
