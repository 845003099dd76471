#include "engine/io/direction.h"

#include <cctype>
#include <cmath>
#include <sstream>

namespace hapvox::engine::io {

std::string direction_problem(const Mat3d& direction) {
  constexpr double kTolerance = 1e-4;
  if (!direction.allFinite()) return "not finite";
  for (int a = 0; a < 3; ++a) {
    const double length = direction.col(a).norm();
    if (std::abs(length - 1.0) > kTolerance) {
      std::ostringstream msg;
      msg << "not orthonormal (a sheared or scaled grid): column " << a << " has length " << length;
      return msg.str();
    }
    for (int b = a + 1; b < 3; ++b) {
      const double cosine = direction.col(a).dot(direction.col(b));
      if (std::abs(cosine) > kTolerance) {
        std::ostringstream msg;
        msg << "not orthonormal (a sheared grid): columns " << a << " and " << b
            << " meet at cosine " << cosine;
        return msg.str();
      }
    }
  }
  return "";
}

std::string orientation_code(const Mat3d& direction) {
  static const char kFrom[3][2] = {{'R', 'L'}, {'A', 'P'}, {'I', 'S'}};
  std::string code;
  for (int a = 0; a < 3; ++a) {
    int major = 0;
    direction.col(a).cwiseAbs().maxCoeff(&major);
    code += kFrom[major][direction(major, a) < 0.0 ? 1 : 0];
  }
  return code;
}

bool orientation_code_valid(const std::string& code) {
  if (code == "???") return true;
  if (code.size() != 3) return false;
  bool seen[3] = {false, false, false};
  for (char c : code) {
    const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    const int axis = (u == 'R' || u == 'L')   ? 0
                     : (u == 'A' || u == 'P') ? 1
                     : (u == 'I' || u == 'S') ? 2
                                              : -1;
    if (axis < 0 || seen[axis]) return false;
    seen[axis] = true;
  }
  return true;
}

}  // namespace hapvox::engine::io
