// band.cpp: the band's rules, stated once: the YAML reader (section `band`) and Band::validate()
// apply these specs (see ecmor/model/band.hpp).
#include "ecmor/model/band.hpp"

#include "ecmor/base/options.hpp"

namespace ecmor {

const OptionSpecs<Band>& Band::specs() {
  static const OptionSpecs<Band> specs(
      {
          option("f_min_hz", &Band::f_min_hz,
                 "lower edge of the band, never 0: the band is sampled in log scale, and f = 0 is "
                 "a pole of H for a model with rigid-body modes (a free-floating body); for a band "
                 "starting near 0 give e.g. 1e-3 · f_max_hz")
              .range(Range::above(0).finite())
              .because("the band is sampled in log scale, and f = 0 is a pole of H for a model "
                       "with rigid-body modes, e.g. a free-floating body")
              .unit("Hz")
              .required(),
          option("f_max_hz", &Band::f_max_hz, "upper edge of the band, > f_min_hz")
              .range(Range::above(0).finite())
              .unit("Hz")
              .required(),
      },
      {[](const Band& b, const OptionCheck<Band>& check) {
        if (!(b.f_max_hz > b.f_min_hz))
          check.fail(b.f_max_hz, "must be > f_min_hz = " + option_number(b.f_min_hz));
      }});
  return specs;
}

void Band::validate() const { specs().validate(*this, ParameterMap::section("band")); }

}  // namespace ecmor
