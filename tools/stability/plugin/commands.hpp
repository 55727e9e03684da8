// The stability plugin's commands (each returns the process exit status; the descriptor wraps
// them in guarded_command, so an exception never reaches the host).
#pragma once

#include "visnav/host.hpp"

namespace visnav::stability {
int stability_command(int argc, char** argv, HostServices& host);
int stability_sim_command(int argc, char** argv, HostServices& host);
int tune_command(int argc, char** argv, HostServices& host);
int platforms_command(int argc, char** argv, HostServices& host);
}  // namespace visnav::stability
