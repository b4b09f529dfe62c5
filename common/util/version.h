#pragma once
// The renderer's version. It changes whenever an identical job could produce different bits,
// so that images (EXR headers) and farm peers can tell renderers apart. 0.3.0: leases of adaptive
// units (Lease.adaptive), which a 0.2.0 worker would ignore and trace the wrong samples. 0.4.0:
// participating media (a 0.3.0 worker refuses such scenes), and a mirror inside a closed glass
// mesh is simulated where 0.3.0 dropped it as unreachable (other bits for those scenes). 0.5.0:
// a pinhole's sensor sits at f (its angle no longer depends on look_at), fov_axis, glTF cameras'
// vertical yfov, photometric glTF lights, solid glTF glass and thin walls (other bits for those
// scenes; a 0.4.0 worker would refuse fov_axis and thin_walled). 0.6.0: triangles far larger
// than the scene tested in double, Embree's scale for scenes beyond 2^32, quad lights' power held
// against rounding, and a scattered ray approaching a plane within its margin meets it (other bits
// for such scenes, and for the rare ray beside an edge). 0.7.0: every unit of a job is traced with
// the job's Embree kernel (Lease.kernel, util/trace_kernel.h), which a 0.6.0 worker would ignore.
namespace lensfarm {
inline constexpr const char* kRendererVersion = "lensfarm-renderer/0.7.0";
}
