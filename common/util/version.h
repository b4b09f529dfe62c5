#pragma once
// The renderer's version. It changes whenever an identical job could produce different bits,
// so that images (EXR headers) and farm peers can tell renderers apart. 0.3.0: leases of adaptive
// units (Lease.adaptive), which a 0.2.0 worker would ignore and trace the wrong samples.
namespace lensfarm {
inline constexpr const char* kRendererVersion = "lensfarm-renderer/0.3.0";
}
