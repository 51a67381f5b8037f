// The one exception type for bad input: the apps print what() and exit 2 (a Python binding raises ValueError).
#pragma once

#include <stdexcept>
#include <string>

namespace obsgain {

// Every invalid input the user can give ends up here. The message is one line whatever it quotes from a file
// (control characters become spaces) and at most 1000 characters.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(one_line(message)) {}

 private:
  static std::string one_line(std::string text) {
    for (char& c : text)
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
    if (text.size() > 1000) text = text.substr(0, 980) + "... (cut)";
    return text;
  }
};

}  // namespace obsgain
