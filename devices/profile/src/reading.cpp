#include "rtukit/devices/profile/reading.hpp"

#include <fmt/format.h>

#include <array>
#include <optional>

#include "rtukit/devices/profile/register_map.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/profile/typed_value.hpp"

namespace rtukit::profile {

Outcome<std::vector<Selected>> select_rows(const Profile& p, std::span<const std::string> keys,
                                           bool for_write) {
  const RegisterMap map(p.rows);
  std::vector<Selected> out;
  if (keys.empty()) {
    for (const Row& r : p.rows) {
      if (!r.readable()) continue;
      for (unsigned i = 0; i < r.repeat; ++i) out.push_back({&r, i});
    }
    return out;
  }
  for (const std::string& typed : keys) {
    // key, or key[i] for an entry of a repeated block (0-based). The index
    // is checked before the key, as the CLI always has.
    std::string key = typed;
    std::optional<unsigned> index;
    if (const size_t open = typed.find('['); open != std::string::npos && typed.ends_with(']')) {
      key = typed.substr(0, open);
      const Outcome<int64_t> n =
          parse_number(typed.substr(open + 1, typed.size() - open - 2), "index", 0, 0xFFFF);
      if (!n.ok()) return n.error();
      index = static_cast<unsigned>(*n);
    }
    const Row* r = find_row(map, key);
    if (!r) {
      // The known keys in the reason: a typo is fixed from the message alone.
      std::string known;
      for (const Row& row : p.rows) known += (known.empty() ? "" : ", ") + std::string(row.key);
      const Row* near = nearest_row(map, key);
      return Status(
          Errc::invalid_argument,
          fmt::format("no register '{}' in {}{} (registers: {})", key, p.name,
                      near ? fmt::format(": did you mean '{}'?", near->key) : std::string(), known));
    }
    if (!for_write && !r->readable())
      return Status(Errc::invalid_argument, fmt::format("{} is write-only", r->key));
    if (index && *index >= r->repeat)
      return Status(Errc::invalid_argument, fmt::format("{} has entries 0..{}", r->key, r->repeat - 1));
    if (index || r->repeat == 1) {
      out.push_back({r, index.value_or(0)});
    } else {
      for (unsigned i = 0; i < r->repeat; ++i) out.push_back({r, i});
    }
  }
  return out;
}

std::string entry_name(const Selected& s) {
  return s.row->repeat > 1 ? fmt::format("{}[{}]", s.row->key, s.index) : std::string(s.row->key);
}

Error read_words(Master& m, UnitId unit, Space space, uint16_t address, std::span<uint16_t> out) {
  switch (space) {
    case Space::holding:
      return m.read_holding_registers(unit, address, out);
    case Space::input:
      return m.read_input_registers(unit, address, out);
    case Space::coil:
    case Space::discrete: {
      std::vector<uint8_t> bits(out.size());  // one element per bit: 0 or 1
      const Error e = space == Space::coil ? m.read_coils(unit, address, bits)
                                           : m.read_discrete_inputs(unit, address, bits);
      for (size_t i = 0; i < out.size(); ++i) out[i] = bits[i];
      return e;
    }
  }
  return Errc::invalid_argument;
}

std::vector<ReadValue> read_selected(Master& master, UnitId unit, std::span<const Selected> selected) {
  std::vector<ReadValue> values;
  values.reserve(selected.size());
  // Adjacent entries of one space go in one request (up to 125 registers):
  // a device's status is read in as few round trips as its layout allows.
  size_t i = 0;
  while (i < selected.size()) {
    const Row& first = *selected[i].row;
    const uint16_t start = first.entry_address(selected[i].index);
    size_t j = i + 1;
    uint32_t end = uint32_t{start} + first.words();
    while (j < selected.size() && selected[j].row->space == first.space &&
           selected[j].row->entry_address(selected[j].index) == end &&
           end - start + selected[j].row->words() <= kMaxReadRegisters) {
      end += selected[j].row->words();
      ++j;
    }
    std::vector<uint16_t> words(end - start);
    const Error e = read_words(master, unit, first.space, start, words);
    for (size_t k = i; k < j; ++k) {
      const Row& r = *selected[k].row;
      const size_t offset = r.entry_address(selected[k].index) - start;
      values.push_back(
          {selected[k], e ? 0 : RegisterMap::decode(r, std::span(words).subspan(offset, r.words())), e});
    }
    i = j;
  }
  return values;
}

ValuesJson values_json(std::span<const ReadValue> values) {
  ValuesJson out;
  for (const ReadValue& v : values) {
    if (v.error) {
      out.ok = false;
      out.values[entry_name(v.entry)] = {{"error", std::string(v.error.text())}};
    } else {
      out.values[entry_name(v.entry)] = entry_json(*v.entry.row, v.raw);
    }
  }
  return out;
}

Outcome<KeyWrite> plan_key_write(const Profile& p, std::string_view key, std::string_view value) {
  const std::string typed(key);
  Outcome<std::vector<Selected>> selected = select_rows(p, std::span(&typed, 1), true);
  if (!selected) return selected.error();
  if (selected->size() != 1)
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("{} is a block: name one entry, {}[i]", key, key));
  const Row& r = *(*selected)[0].row;
  if (!r.writable()) return rtukit::Status(Errc::invalid_argument, fmt::format("{} is read-only", r.key));
  if (r.role == Role::hold || r.role == Role::pulse)
    return rtukit::Status(
        Errc::refused, fmt::format("{} is a {} command: use `rtukit {} {}`", r.key, role_name(r.role), p.name,
                                   r.role == Role::hold ? "hold" : "pulse"));
  Outcome<int64_t> raw = parse_value(r, value);
  if (!raw) return rtukit::Status(Errc::invalid_argument, std::string(raw.error().reason()));
  return KeyWrite{(*selected)[0], *raw};
}

Error write_entry(Master& master, UnitId unit, const KeyWrite& w) {
  const Row& r = *w.entry.row;
  std::array<uint16_t, 2> words{};
  RegisterMap::encode(r, w.raw, std::span(words.data(), r.words()));
  const uint16_t address = r.entry_address(w.entry.index);
  if (r.space == Space::coil) return master.write_single_coil(unit, address, words[0] != 0);
  if (r.words() == 1) return master.write_single_register(unit, address, words[0]);
  return master.write_multiple_registers(unit, address, std::span<const uint16_t>(words.data(), 2));
}

}  // namespace rtukit::profile
