// microshadow: the generic VNDF-based micro-shadowing term on OpenCL (the commands: host/cli/).
#include "cli/common.hpp"

int main(int argc, char** argv) { return ms::cli::run_program(argc, argv); }
