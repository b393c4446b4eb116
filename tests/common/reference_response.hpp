#pragma once
/// \file reference_response.hpp
/// The benchmark models' independent reference responses, models/NAME/ref_freq_response.csv
/// (computed by the data's authors with SciPy/SuperLU, see models/README.md): '#' comment
/// lines, then a header line naming the columns omega (rad/s), sigma_max and re_H_i_j, im_H_i_j
/// (output i, input j, from 0), then one row per frequency. Columns are found by their header
/// names, not by position.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"

namespace ecmor::test {

struct ReferenceResponse {
  std::vector<double> omega;     ///< rad/s, in file order
  std::vector<ComplexMatrix> H;  ///< p x m, one per omega
  std::vector<double> f_hz() const {
    std::vector<double> f;
    for (double w : omega) f.push_back(w / kTwoPi);
    return f;
  }
};

/// Reads `csv` for a p x m model. \throws std::runtime_error naming the file for a missing file,
/// no omega column, a response column outside p x m, or a cell that is not a number.
inline ReferenceResponse read_reference_response(const std::filesystem::path& csv, Index p,
                                                 Index m) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error(csv.string() + ": cannot open");
  auto fail = [&](const std::string& why) { throw std::runtime_error(csv.string() + ": " + why); };
  ReferenceResponse ref;
  // Per column: -1 omega, -2 ignored, else 2 (i m + j) + (0 real, 1 imaginary).
  std::vector<long> role;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (role.empty()) {
      bool has_omega = false;
      for (const std::string& h : cells) {
        int i = -1, j = -1;
        if (h == "omega") {
          role.push_back(-1);
          has_omega = true;
        } else if ((h.rfind("re_H_", 0) == 0 || h.rfind("im_H_", 0) == 0) &&
                   std::sscanf(h.c_str() + 5, "%d_%d", &i, &j) == 2) {
          if (i < 0 || j < 0 || i >= p || j >= m) {
            fail("column " + h + " outside the model's " + std::to_string(p) + " x " +
                 std::to_string(m));
          }
          role.push_back(2 * (static_cast<long>(i) * m + j) + (h[0] == 'r' ? 0 : 1));
        } else {
          role.push_back(-2);
        }
      }
      if (!has_omega) fail("no omega column in the header");
      continue;
    }
    ComplexMatrix H = ComplexMatrix::Zero(p, m);
    for (std::size_t c = 0; c < cells.size() && c < role.size(); ++c) {
      if (role[c] == -2) continue;
      std::size_t used = 0;
      double v = 0.0;
      try {
        v = std::stod(cells[c], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0) fail("'" + cells[c] + "' is not a number");
      if (role[c] == -1) {
        ref.omega.push_back(v);
        continue;
      }
      Complex& h = H((role[c] / 2) / m, (role[c] / 2) % m);
      if (role[c] % 2 == 0)
        h.real(v);
      else
        h.imag(v);
    }
    ref.H.push_back(H);
  }
  if (ref.omega.size() != ref.H.size()) fail("a row without omega");
  return ref;
}

}  // namespace ecmor::test
