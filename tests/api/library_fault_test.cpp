// The fault-injection test hook (MICROSHADOW_FAIL_DEVICE, read by the scheduler) on the library's
// path: a device that fails has its work rerun on the other device, the values unchanged, and with no
// other device the call fails. Two devices need POCL_DEVICES set before PoCL starts, so the checks run
// in a child process of this test binary (LibraryFaultInjection.InAChildWithTwoDevices), which the
// parent starts with the variables set.
#include <gtest/gtest.h>
#include <microshadow/microshadow.hpp>

#include <cstdlib>
#include <cstring>
#include <string>
#include <system_error>
#include <vector>

#include "cli_runner.hpp"
#include "device/runtime.hpp"
#include "platform/process.hpp"

namespace {

constexpr const char* kFaultChildVariable = "MICROSHADOW_LIBRARY_FAULT_CHILD";

std::vector<microshadow::Query> fault_test_queries() {
    std::vector<microshadow::Query> queries;
    for (int i = 0; i < 12; ++i)
        queries.push_back(microshadow::isotropic_query(0.2 + 0.05 * i, 0.3 + 0.05 * i, 0.9 - 0.04 * i, microshadow::Roughness(0.3 + 0.05 * i), 15.0 * i));
    return queries;
}

// The checks, in the child (skipped when the parent did not start it).
TEST(LibraryFaultInjection, InAChildWithTwoDevices) {
    if (!std::getenv(kFaultChildVariable)) GTEST_SKIP() << "run by LibraryFaultInjection.AFailingDeviceIsRerunThroughTheCppApi";
    ASSERT_EQ(ms::ocl::select_devices("all").size(), 2u) << "POCL_DEVICES='pthread pthread' gives two devices";
    microshadow::SamplingOptions o;
    o.method = microshadow::Method::sampled;
    o.samples = 4096;
    o.device = "all";
    const auto queries = fault_test_queries();
    microshadow::BakeOptions b;
    b.layout = "custom";
    b.size = 4;
    b.roughness = {0.3, 0.8};
    b.sampling.samples = 1024;
    b.sampling.device = "all";

    ASSERT_EQ(ms::platform::set_environment("MICROSHADOW_FAIL_DEVICE", ""), 0);
    const auto clean = microshadow::evaluate(queries, o);
    const microshadow::Lut clean_lut = microshadow::bake(b);
    // Device 0 fails on its first item: its items are rerun on device 1, and the values do not change.
    ASSERT_EQ(ms::platform::set_environment("MICROSHADOW_FAIL_DEVICE", "0:0"), 0);
    const auto faulty = microshadow::evaluate(queries, o);
    ASSERT_EQ(faulty.size(), clean.size());
    for (std::size_t i = 0; i < clean.size(); ++i) {
        EXPECT_EQ(std::memcmp(&faulty[i].value, &clean[i].value, sizeof(double)), 0) << i;
        EXPECT_EQ(std::memcmp(&faulty[i].std_error, &clean[i].std_error, sizeof(double)), 0) << i;
    }
    const microshadow::Lut faulty_lut = microshadow::bake(b);
    for (std::uint32_t c = 0; c < 2; ++c)
        for (std::uint32_t v = 0; v < 4; ++v)
            for (std::uint32_t l = 0; l < 4; ++l)
                for (std::uint32_t n = 0; n < 4; ++n)
                    EXPECT_EQ(faulty_lut.texel(c, v, l, n), clean_lut.texel(c, v, l, n)) << c << " " << v << " " << l << " " << n;
    // With device 0 alone nothing is left to rerun on: the call fails. Before, the hook never reached
    // the library, and this returned values.
    o.device = "0";
    EXPECT_ANY_THROW(microshadow::evaluate(queries, o));
    b.sampling.device = "0";
    EXPECT_ANY_THROW(microshadow::bake(b));
    ASSERT_EQ(ms::platform::set_environment("MICROSHADOW_FAIL_DEVICE", ""), 0);
}

TEST(LibraryFaultInjection, AFailingDeviceIsRerunThroughTheCppApi) {
    if (std::getenv(kFaultChildVariable)) GTEST_SKIP() << "the child runs the checks";
    std::error_code ec;
    const std::string self = ms::platform::executable_path(ec);
    ASSERT_FALSE(ec) << ec.message();
    const auto r = ms::testing::run_shell("POCL_DEVICES='pthread pthread' " + std::string(kFaultChildVariable) + "=1 " +
                                          ms::testing::shell_quote(self) +
                                          " --gtest_filter=LibraryFaultInjection.InAChildWithTwoDevices 2>&1");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("[  PASSED  ] 1 test"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("SKIPPED"), std::string::npos) << r.output;
}

}  // namespace
