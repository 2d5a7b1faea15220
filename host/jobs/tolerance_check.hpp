// How a job's values compare with the tolerance asked of them (eval, area eval, bake): the job records
// it in its metadata, the command prints its summary and chooses the exit status (cli/common.hpp).
#pragma once

#include <cstdint>
#include <string>

namespace ms {

// add() each value's estimated error. An error that is NaN counts as above (an estimate that cannot be
// checked is no estimate).
struct ToleranceCheck {
    double tolerance = 0;  // 0: nothing was asked (every value passes)
    std::uint64_t values = 0, over = 0;
    double worst = 0;  // the largest estimated error above the tolerance
    void add(double error);
    bool met() const { return over == 0; }
    // "(tolerance 1e-10 met)" or "(TOLERANCE NOT MET: 3 of 6 values above 1e-10, worst 1.7e-05)" for
    // a summary line; "" when no tolerance was asked.
    std::string summary() const;
};

}  // namespace ms
