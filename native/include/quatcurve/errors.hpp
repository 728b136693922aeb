// Error type of the native library. Every public function reports bad input by throwing
// InvalidArgument with a message naming the argument and, for arrays, the element index
// ("q[3]: zero-length quaternion"). The Python module maps it to ValueError.
#pragma once

#include <stdexcept>
#include <string>

namespace quatcurve {

class InvalidArgument : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

}  // namespace quatcurve
