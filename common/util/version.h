#pragma once
// The renderer's version. It changes whenever an identical job could produce different bits,
// so that images (EXR headers) and, later, farm peers can tell renderers apart.
namespace lensfarm {
inline constexpr const char* kRendererVersion = "lensfarm-renderer/0.2.0";
}
