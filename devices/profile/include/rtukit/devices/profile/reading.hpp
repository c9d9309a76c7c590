// rtukit device profiles, host side: reading a device's registers by name.
// A front-end names entries as people type them ("speed", "p1_speed[3]"),
// reads them from a device through a driver Master, and shows them; this is
// the part between the typed keys and the shown values that is the same for
// every front-end (the CLI's `get`, `watch`, `status`, `read --map`).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/driver/master.hpp"

namespace rtukit::profile {

/// One entry of a row: the row and, for a repeated block, which entry.
/// `row` points into the profile's rows: it lives as long as the profile.
struct Selected {
  const Row* row;
  unsigned index = 0;
};

/// The entries named by `keys` ("speed", "p1_speed[3]", "p1_speed" = every
/// entry of the block), in the order named; no keys: every entry of every
/// readable row. A write-only row may be named only `for_write`.
/// Errors: invalid_argument, the reason says why: "no register 'x' in
/// testdev (registers: speed, ...)", "command is write-only", "seg_speed has
/// entries 0..3", or the index's own ("index 'x' is not a number ...").
Outcome<std::vector<Selected>> select_rows(const Profile& p, std::span<const std::string> keys,
                                           bool for_write);

/// "key", or "key[i]" for an entry of a repeated block.
std::string entry_name(const Selected& s);

/// One entry as read: its raw value (RegisterMap::decode), or the error of
/// the request that should have carried it (`raw` is then 0).
struct ReadValue {
  Selected entry;
  int64_t raw = 0;
  Error error;
};

/// One request for out.size() words (holding, input) or bits (coils,
/// discrete inputs; each bit one word, 0 or 1) in `space` from `address`.
/// Precondition: out.size() within the function's limit (125 registers,
/// 2000 bits). Errors: the Master's.
Error read_words(Master& master, UnitId unit, Space space, uint16_t address, std::span<uint16_t> out);

/// Reads the entries from the device at `unit`, one ReadValue for each, in
/// order. Entries next to each other in one space (each starting where the
/// one before ends) go in one request of at most 125 registers; a failed
/// request marks each of its entries with its error, and the others are
/// still read.
std::vector<ReadValue> read_selected(Master& master, UnitId unit, std::span<const Selected> selected);

/// The values as JSON (docs/json.md's "values"): {entry_name: entry_json},
/// an entry that failed {"error": its text}; `ok` false when any failed.
struct ValuesJson {
  nlohmann::ordered_json values = nlohmann::ordered_json::object();
  bool ok = true;
};
ValuesJson values_json(std::span<const ReadValue> values);

/// One entry to write by key (`rtukit <device> set KEY VALUE`): the entry
/// and its raw value, checked against the row.
struct KeyWrite {
  Selected entry;
  int64_t raw = 0;
};

/// The write of `value` (as people write it: "80", "80%", "outdoor", "30:00")
/// to the entry `key` ("speed", "seg_speed[3]"). Errors: invalid_argument
/// (the key's, a block named whole: "seg_speed is a block: name one entry,
/// seg_speed[i]", "x is read-only", the value's, from parse_value); refused:
/// a hold or pulse command ("stand is a hold command: use `rtukit rehand6600
/// hold`"): motion and momentary commands need their device's verbs (leases,
/// releases, rules), never a bare register write.
Outcome<KeyWrite> plan_key_write(const Profile& p, std::string_view key, std::string_view value);

/// Writes `w` to the device at `unit`: FC05 for a coil, FC06 for one
/// register, FC10 for two. Errors: the Master's.
Error write_entry(Master& master, UnitId unit, const KeyWrite& w);

}  // namespace rtukit::profile
