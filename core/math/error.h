// The one error type of the libraries: bad input of any kind, with a message a user can act on.
#pragma once

#include <stdexcept>
#include <string>

namespace tesswave {

// Thrown for bad input (files, meshes, options, bitstreams). The command line catches it and
// prints its message; the libraries never print or exit.
class Error : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

}  // namespace tesswave
