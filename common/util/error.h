#pragma once
// Errors a user can fix: a bad scene file, a bad flag, an unwritable output. Each carries the
// place (file, field or flag) so the CLI prints exactly one line naming it.
#include <stdexcept>
#include <string>

namespace lensfarm {

class InputError : public std::runtime_error {
 public:
  // `where` is a file, "file: field.path" or a flag; `what` says what is wrong with it.
  InputError(std::string where, const std::string& what)
      : std::runtime_error(where + ": " + what), where_(std::move(where)) {}
  const std::string& where() const { return where_; }

 private:
  std::string where_;
};

}  // namespace lensfarm
