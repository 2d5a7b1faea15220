// An exact bake's summary speaks of what the exact method did (its engine, its azimuth rule, its largest
// estimated texel error against the tolerance), not of samples and batches it does not have; a missed
// tolerance names what would help the exact method, not --max-batches.
#include <gtest/gtest.h>

#include <string>

#include "cli_runner.hpp"

namespace exact_bake_summary {
using ms::testing::cli;

class ExactBakeSummary : public ms::testing::ScratchDirTest {
protected:
    ExactBakeSummary() : ScratchDirTest("exact_bake_summary") {}
};

TEST_F(ExactBakeSummary, SaysWhatTheExactMethodDidAndNothingOfSamples) {
    const auto r = cli("bake --size 8 --method exact --backend oracle --out " + ms::testing::shell_quote(path("x.exr")));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("exact method (the C++ evaluator (double))"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("azimuth means of T on "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("largest estimated texel error "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("against the tolerance 1e-06 (tolerance met)"), std::string::npos) << r.output;
    for (const char* sampled_word : {"samples per batch", "batches", "azimuth node", "std error"})
        EXPECT_EQ(r.output.find(sampled_word), std::string::npos) << sampled_word << " in: " << r.output;
}

TEST_F(ExactBakeSummary, AMissedToleranceOfTheFloatKernelNamesWhatWouldMeetIt) {
    const auto r = cli("bake --size 8 --method exact --exact-float --out " + ms::testing::shell_quote(path("f.exr")));
    EXPECT_EQ(r.exit_code, 3) << r.output;
    EXPECT_NE(r.output.find("exact method (the float kernel on every device)"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("(TOLERANCE NOT MET: the float kernel's rounding stops it; leave out --exact-float"),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("or give a looser --tolerance)"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("--max-batches"), std::string::npos) << r.output;
}

}  // namespace exact_bake_summary
