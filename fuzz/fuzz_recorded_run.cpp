// libFuzzer target: the recorded-run formats — CSV tables (odometry.csv, commands.csv,
// frames.csv) and run.yaml. The first byte chooses the parser.
#include <cstdint>

#include "visnav/config.hpp"
#include "visnav/recorded/csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  if (data[0] & 1) {
    auto table = visnav::recorded::parse_csv(text, "fuzz.csv");
    if (!table) return 0;
    for (const auto& row : table->rows)
      for (std::size_t c = 0; c < table->header.size() && c < row.fields.size(); ++c)
        (void)visnav::recorded::csv_number(row.fields[c], table->where(row), table->header[c]);
  } else {
    (void)visnav::parse_yaml_string(text, "run.yaml");
  }
  return 0;
}
