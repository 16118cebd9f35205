#include "fleet/manifest.hpp"

#include <array>
#include <cctype>
#include <map>

#include "core/errors.hpp"
#include "files/read_file.hpp"

namespace insalign::fleet {
namespace {

namespace fs = std::filesystem;

constexpr std::array<const char*, 6> kColumns{"car", "date", "kind", "input", "extrinsic", "options"};

struct Field {
  std::string text;
  int line = 0;
  int column = 0;  ///< 1-based character column where the field starts
};
using Record = std::vector<Field>;

std::string where(int line, int column) { return "line " + std::to_string(line) + ", column " + std::to_string(column); }

// RFC 4180 records: fields separated by commas, records by CRLF or LF, a quoted field may hold
// commas, line breaks and "" (one quote). Lines that are entirely empty are skipped.
class CsvReader {
 public:
  CsvReader(std::string_view text, const std::string& file) : text_(text), file_(file) {}

  bool next(Record& record) {
    record.clear();
    while (pos_ < text_.size() && (text_[pos_] == '\n' || text_[pos_] == '\r')) advance_line_break();
    if (pos_ >= text_.size()) return false;
    for (;;) {
      record.push_back(read_field());
      if (pos_ >= text_.size()) return true;
      const char c = text_[pos_];
      if (c == ',') {
        advance();
        continue;
      }
      advance_line_break();  // read_field stops only at a comma, a line break or the end
      return true;
    }
  }

 private:
  Field read_field() {
    Field f{"", line_, column_};
    if (pos_ < text_.size() && text_[pos_] == '"') return read_quoted(f);
    while (pos_ < text_.size() && text_[pos_] != ',' && text_[pos_] != '\n' && text_[pos_] != '\r') {
      if (text_[pos_] == '"')
        throw InputError(file_, where(line_, column_), "a quote inside an unquoted field (quote the whole field and double the quote)");
      if (text_[pos_] == '\0') throw InputError(file_, where(line_, column_), "a NUL byte");
      f.text += text_[pos_];
      advance();
    }
    return f;
  }

  Field read_quoted(Field f) {
    advance();  // the opening quote
    for (;;) {
      if (pos_ >= text_.size()) throw InputError(file_, where(f.line, f.column), "the quoted field is not closed");
      const char c = text_[pos_];
      if (c == '"') {
        advance();
        if (pos_ < text_.size() && text_[pos_] == '"') {
          f.text += '"';
          advance();
          continue;
        }
        if (pos_ < text_.size() && text_[pos_] != ',' && text_[pos_] != '\n' && text_[pos_] != '\r')
          throw InputError(file_, where(line_, column_), "text after the closing quote of a field");
        return f;
      }
      if (c == '\0') throw InputError(file_, where(line_, column_), "a NUL byte");
      if (c == '\n' || c == '\r') {
        f.text += '\n';
        advance_line_break();
      } else {
        f.text += c;
        advance();
      }
    }
  }

  void advance() {
    ++pos_;
    ++column_;
  }
  void advance_line_break() {
    if (text_[pos_] == '\r' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '\n') ++pos_;
    ++pos_;
    ++line_;
    column_ = 1;
  }

  std::string_view text_;
  const std::string& file_;
  std::size_t pos_ = 0;
  int line_ = 1;
  int column_ = 1;
};

bool is_digits(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

// ISO 8601 calendar date, optionally with a time: YYYY-MM-DD[Thh:mm[:ss[.fff]][Z|+hh:mm|-hh:mm]].
bool is_iso_date(std::string_view s) {
  if (s.size() < 10 || !is_digits(s.substr(0, 4)) || s[4] != '-' || !is_digits(s.substr(5, 2)) || s[7] != '-' ||
      !is_digits(s.substr(8, 2)))
    return false;
  const int month = std::stoi(std::string(s.substr(5, 2))), day = std::stoi(std::string(s.substr(8, 2)));
  if (month < 1 || month > 12 || day < 1 || day > 31) return false;
  if (s.size() == 10) return true;
  if (s[10] != 'T' || s.size() < 16 || !is_digits(s.substr(11, 2)) || s[13] != ':' || !is_digits(s.substr(14, 2)))
    return false;
  for (char c : s.substr(16))
    if (!std::isdigit(static_cast<unsigned char>(c)) && c != ':' && c != '.' && c != 'Z' && c != '+' && c != '-') return false;
  return true;
}

// A car names a folder of the results: letters, digits, '.', '_', '-', not starting with '.'.
bool is_car_name(std::string_view s) {
  if (s.empty() || s[0] == '.' || s.size() > 200) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-') return false;
  return true;
}

std::map<std::string, std::size_t> header_columns(const Record& header, const std::string& file) {
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < header.size(); ++i) {
    std::string name = header[i].text;
    if (i == 0 && name.rfind("\xEF\xBB\xBF", 0) == 0) name.erase(0, 3);  // a UTF-8 byte order mark
    bool known = false;
    for (const char* c : kColumns) known = known || name == c;
    if (!known)
      throw InputError(file, where(header[i].line, header[i].column),
                       "unknown column \"" + name + "\" (the columns are car, date, kind, input, extrinsic, options)");
    if (index.count(name)) throw InputError(file, where(header[i].line, header[i].column), "column \"" + name + "\" appears twice");
    index[name] = i;
  }
  for (const char* c : kColumns)
    if (!index.count(c)) throw InputError(file, where(1, 1), std::string("missing column \"") + c + "\" in the header");
  return index;
}

void check_words(const Field& f, const char* column, const std::string& file) {
  for (const std::string& w : split_words(f.text, file, where(f.line, f.column)))
    if (w == "--out" || w.rfind("--out=", 0) == 0)
      throw InputError(file, where(f.line, f.column), std::string(column) + " must not hold --out (the fleet chooses the output folder)");
}

ManifestRow make_row(const Record& r, const std::map<std::string, std::size_t>& col, const std::string& file) {
  const Field& car = r[col.at("car")];
  const Field& date = r[col.at("date")];
  const Field& kind = r[col.at("kind")];
  const Field& input = r[col.at("input")];
  const Field& extrinsic = r[col.at("extrinsic")];
  const Field& options = r[col.at("options")];
  if (!is_car_name(car.text))
    throw InputError(file, where(car.line, car.column),
                     "car \"" + car.text + "\" is not a folder name (letters, digits, '.', '_', '-'; not starting with '.')");
  if (!is_iso_date(date.text))
    throw InputError(file, where(date.line, date.column), "date \"" + date.text + "\" is not ISO 8601 (YYYY-MM-DD[Thh:mm[:ss]])");
  if (kind.text != "check" && kind.text != "calibrate")
    throw InputError(file, where(kind.line, kind.column), "unknown kind \"" + kind.text + "\" (check or calibrate)");
  if (split_words(input.text, file, where(input.line, input.column)).empty())
    throw InputError(file, where(input.line, input.column), "empty input (e.g. --bag drives/a.mcap)");
  check_words(input, "input", file);
  check_words(options, "options", file);
  if (kind.text == "check" && extrinsic.text.empty())
    throw InputError(file, where(extrinsic.line, extrinsic.column), "a check row needs the installed extrinsic FILE");
  if (kind.text == "calibrate" && !extrinsic.text.empty())
    throw InputError(file, where(extrinsic.line, extrinsic.column),
                     "a calibrate row has an empty extrinsic (give an initial guess as \"--init FILE\" in options)");
  return {car.text, date.text, kind.text, input.text, extrinsic.text, options.text, car.line};
}

}  // namespace

std::vector<std::string> split_words(std::string_view text, const std::string& file_name, const std::string& location) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
    } else if (c == '\'' || c == '"') {
      const std::size_t end = text.find(c, i + 1);
      if (end == std::string_view::npos)
        throw InputError(file_name, location, std::string("unterminated ") + (c == '"' ? "double" : "single") + " quote in \"" +
                                                  std::string(text) + "\"");
      word.append(text.substr(i + 1, end - i - 1));
      i = end;
      in_word = true;
    } else if (c == '\\' && i + 1 < text.size()) {
      word += text[++i];
      in_word = true;
    } else {
      word += c;
      in_word = true;
    }
  }
  if (in_word) words.push_back(word);
  return words;
}

Manifest parse_manifest(std::string_view text, const std::string& file_name) {
  CsvReader reader(text, file_name);
  Record header;
  if (!reader.next(header)) throw InputError(file_name, "line 1", "empty manifest (a header car,date,kind,input,extrinsic,options is needed)");
  const std::map<std::string, std::size_t> col = header_columns(header, file_name);
  Manifest m;
  std::map<std::string, int> first_line;  // id -> line
  Record record;
  while (reader.next(record)) {
    if (record.size() != header.size())
      throw InputError(file_name, where(record.front().line, record.back().column),
                       "the row has " + std::to_string(record.size()) + " fields, the header " + std::to_string(header.size()));
    ManifestRow row = make_row(record, col, file_name);
    const auto [it, fresh] = first_line.emplace(row.id(), row.line);
    if (!fresh)
      throw InputError(file_name, where(row.line, 1),
                       "duplicate id " + row.id() + " (lines " + std::to_string(it->second) + " and " + std::to_string(row.line) + ")");
    m.rows.push_back(std::move(row));
  }
  return m;
}

Manifest read_manifest(const std::filesystem::path& path) {
  const std::string text = io::read_file(path);
  Manifest m = parse_manifest(text, path.string());
  m.file = fs::absolute(path).lexically_normal();
  m.folder = m.file.parent_path();
  return m;
}

}  // namespace insalign::fleet
