#pragma once
/// \file reject_case.hpp
/// One bad input of a text reader (up to two files' contents) and the part of the error message
/// it must produce (file, line, rule), for the parameterised rejection tests of the readers.

#include <ostream>

namespace ecmor::test {

struct RejectCase {
  const char* name;      ///< what is wrong, for the test output
  const char* first;     ///< the first file's contents (nullptr: the file is not written)
  const char* second;    ///< the second file's contents, if the reader takes two
  const char* expected;  ///< a substring of the message
};

inline std::ostream& operator<<(std::ostream& out, const RejectCase& c) { return out << c.name; }

}  // namespace ecmor::test
