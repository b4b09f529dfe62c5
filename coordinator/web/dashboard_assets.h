#pragma once
// The dashboard's page (coordinator/web/dashboard/*), compiled into the binary at build time by
// coordinator/web/dashboard/embed.cmake: nothing to build or install on the user's side.
#include <string_view>
#include <vector>

namespace lensfarm {

struct DashboardAsset {
  std::string_view path;  // "/index.html", "/app.js", "/style.css"
  std::string_view contentType;
  std::string_view bytes;
};

const std::vector<DashboardAsset>& dashboardAssets();

}  // namespace lensfarm
