// Error values shared by the library layers; only the command line turns them into exit codes.
#pragma once

#include <stdexcept>
#include <string>

namespace insalign {

/// Bad input: names the file and where in it (line or byte offset), and what is wrong.
class InputError : public std::runtime_error {
 public:
  InputError(std::string file, std::string location, const std::string& problem)
      : std::runtime_error(file + (location.empty() ? "" : ":" + location) + ": " + problem),
        file_(std::move(file)),
        location_(std::move(location)) {}
  const std::string& file() const { return file_; }
  const std::string& location() const { return location_; }

 private:
  std::string file_;
  std::string location_;  ///< "line 12", "byte 4096" or empty
};

/// The data cannot determine the extrinsic; the message says which degrees of freedom and why.
class UnobservableError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace insalign
