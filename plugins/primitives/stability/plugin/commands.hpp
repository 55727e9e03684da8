// The stability plugin's commands (each returns the process exit status; never throws).
#pragma once

#include "visnav/host.hpp"

namespace visnav::stability {
int stability_command(int argc, char** argv, HostServices& host) noexcept;
int stability_sim_command(int argc, char** argv, HostServices& host) noexcept;
int tune_command(int argc, char** argv, HostServices& host) noexcept;
int platforms_command(int argc, char** argv, HostServices& host) noexcept;
}  // namespace visnav::stability
