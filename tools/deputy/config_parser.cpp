// Tokenizer and recursive-descent parser of the procman configuration format (config.h).
// The grammar follows bot2-procman's sheriff_config.py; this is our own implementation.
//
//   config  := { "cmd" command | "group" group | "script" script }
//   command := [STRING] "{" { IDENT "=" (STRING | INTEGER) ";" } "}"
//   group   := STRING "{" { "cmd" command | "group" group } "}"
//   script  := STRING "{" { action } "}"
//   action  := ("start" | "stop" | "restart") target [ "wait" STRING ] ";"
//            | "wait" "ms" INTEGER ";"
//            | "wait" ("cmd" | "group") STRING "status" STRING ";"
//            | "run_script" STRING ";"
//   target  := "everything" | ("cmd" | "group") STRING
#include <cctype>
#include <fstream>
#include <limits>
#include <sstream>

#include "tools/deputy/config.h"

namespace evermap::deputy {
namespace {

enum class Tok { kIdentifier, kString, kInteger, kOpen, kClose, kAssign, kEnd, kEof };

const char* describe(Tok t) {
  switch (t) {
    case Tok::kIdentifier:
      return "a word";
    case Tok::kString:
      return "a quoted string";
    case Tok::kInteger:
      return "an integer";
    case Tok::kOpen:
      return "'{'";
    case Tok::kClose:
      return "'}'";
    case Tok::kAssign:
      return "'='";
    case Tok::kEnd:
      return "';'";
    case Tok::kEof:
      return "end of file";
  }
  return "?";
}

// The token of a one-character punctuation mark; kEof for any other character.
Tok punctuation(char c) {
  switch (c) {
    case '{':
      return Tok::kOpen;
    case '}':
      return Tok::kClose;
    case '=':
      return Tok::kAssign;
    case ';':
      return Tok::kEnd;
    default:
      return Tok::kEof;
  }
}

struct Token {
  Tok type = Tok::kEof;
  std::string text;
  SourcePos pos;
};

// Thrown inside the parser only; parseConfig() turns it into an Error.
struct ParseFailure {
  SourcePos pos;
  std::string message;
};

class Tokenizer {
 public:
  explicit Tokenizer(std::string_view text) : text_(text) {}

  Token next() {
    skipSpaceAndComments();
    Token t;
    t.pos = pos_;
    if (i_ >= text_.size()) return t;
    const char c = text_[i_];
    if (c == '"') return quoted(t);
    if (const Tok p = punctuation(c); p != Tok::kEof) {
      advance();
      t.type = p;
      t.text = std::string(1, c);
      return t;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      t.type = Tok::kIdentifier;
      while (i_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[i_])) ||
                                   text_[i_] == '_' || text_[i_] == '-')) {
        t.text += text_[i_];
        advance();
      }
      return t;
    }
    if (std::isdigit(static_cast<unsigned char>(c))) {
      t.type = Tok::kInteger;
      while (i_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[i_]))) {
        t.text += text_[i_];
        advance();
      }
      return t;
    }
    throw ParseFailure{pos_, std::string("unexpected character '") + c + "'"};
  }

 private:
  void advance() {
    if (text_[i_] == '\n') {
      ++pos_.line;
      pos_.column = 1;
    } else {
      ++pos_.column;
    }
    ++i_;
  }

  void skipSpaceAndComments() {
    while (i_ < text_.size()) {
      if (std::isspace(static_cast<unsigned char>(text_[i_]))) {
        advance();
      } else if (text_[i_] == '#') {
        while (i_ < text_.size() && text_[i_] != '\n') advance();
      } else {
        return;
      }
    }
  }

  Token quoted(Token t) {
    t.type = Tok::kString;
    advance();  // the opening quote
    while (true) {
      if (i_ >= text_.size() || text_[i_] == '\n') {
        throw ParseFailure{t.pos, "unterminated string"};
      }
      char c = text_[i_];
      advance();
      if (c == '"') return t;
      if (c == '\\') {
        if (i_ >= text_.size()) throw ParseFailure{t.pos, "unterminated string"};
        const char e = text_[i_];
        advance();
        c = e == 'n' ? '\n' : e == 'r' ? '\r' : e == 't' ? '\t' : e;
      }
      t.text += c;
    }
  }

  std::string_view text_;
  size_t i_ = 0;
  SourcePos pos_{1, 1};
};

class Parser {
 public:
  explicit Parser(std::string_view text) : tokens_(text) { next_ = tokens_.next(); }

  Config parse() {
    while (next_.type != Tok::kEof) {
      const Token kw = expectWord({"cmd", "group", "script"});
      if (kw.text == "cmd") {
        parseCommand("");
      } else if (kw.text == "group") {
        parseGroup("");
      } else {
        parseScript();
      }
    }
    return std::move(config_);
  }

 private:
  Token take() {
    Token t = std::move(next_);
    next_ = tokens_.next();
    return t;
  }
  bool peekIs(Tok type) const { return next_.type == type; }
  [[noreturn]] void failAt(const SourcePos& pos, std::string message) const {
    throw ParseFailure{pos, std::move(message)};
  }
  [[noreturn]] void failExpected(const std::string& what) const {
    std::string got = describe(next_.type);
    if (next_.type != Tok::kEof) got += " (" + next_.text + ")";
    failAt(next_.pos, "expected " + what + ", got " + got);
  }
  Token expect(Tok type, const std::string& what) {
    if (!peekIs(type)) failExpected(what);
    return take();
  }
  Token expectWord(std::initializer_list<const char*> words) {
    std::string list;
    for (const char* w : words) list += (list.empty() ? "" : " or ") + std::string(w);
    if (!peekIs(Tok::kIdentifier)) failExpected(list);
    for (const char* w : words) {
      if (next_.text == w) return take();
    }
    failExpected(list);
  }
  std::string expectString(const std::string& what) { return expect(Tok::kString, what).text; }

  static void checkName(const Token& t, const char* kind) {
    if (t.text.find('/') != std::string::npos) {
      throw ParseFailure{t.pos, std::string("'/' is not allowed in a ") + kind + " name"};
    }
    if (t.text.find_first_not_of(" \t") == std::string::npos) {
      throw ParseFailure{t.pos, std::string("empty ") + kind + " name"};
    }
  }

  int integerValue(const Token& t, long long lo, long long hi, const std::string& attr) {
    long long v = 0;
    for (char c : t.text) {
      v = v * 10 + (c - '0');
      if (v > hi) break;
    }
    if (v < lo || v > hi) {
      failAt(t.pos, attr + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                        "], got " + t.text);
    }
    return static_cast<int>(v);
  }

  void parseCommand(const std::string& group) {
    CommandSpec cmd;
    cmd.group = group;
    cmd.pos = next_.pos;
    Token name_token;
    if (peekIs(Tok::kString)) {
      name_token = take();
      checkName(name_token, "command");
      cmd.name = name_token.text;
    }
    expect(Tok::kOpen, "'{' after the command name");
    bool has_exec = false;
    while (peekIs(Tok::kIdentifier)) {
      const Token attr = take();
      expect(Tok::kAssign, "'=' after " + attr.text);
      const Token value = peekIs(Tok::kString) || peekIs(Tok::kInteger)
                              ? take()
                              : (failExpected("a string or an integer for " + attr.text), Token{});
      auto needString = [&] {
        if (value.type != Tok::kString) failAt(value.pos, attr.text + " takes a quoted string");
      };
      auto needInteger = [&] {
        if (value.type != Tok::kInteger) failAt(value.pos, attr.text + " takes an integer");
      };
      if (attr.text == "exec") {
        needString();
        cmd.exec = value.text;
        has_exec = true;
      } else if (attr.text == "host") {
        needString();
        cmd.host = value.text;
      } else if (attr.text == "group") {
        // procman's older configs name the group as an attribute; it nests under the block.
        needString();
        const std::string g = normalizeGroupPath(value.text);
        if (!g.empty()) cmd.group = group.empty() ? g : group + "/" + g;
      } else if (attr.text == "auto_respawn") {
        needString();
        if (value.text != "true" && value.text != "false") {
          failAt(value.pos,
                 "auto_respawn must be \"true\" or \"false\", got \"" + value.text + "\"");
        }
        cmd.auto_respawn = value.text == "true";
      } else if (attr.text == "stop_signal") {
        needInteger();
        cmd.stop_signal = integerValue(value, 1, 64, "stop_signal");
      } else if (attr.text == "stop_time_allowed") {
        needInteger();
        cmd.stop_time_allowed_s = integerValue(value, 1, 86400, "stop_time_allowed");
      } else if (attr.text == "start_delay_ms") {
        needInteger();
        cmd.start_delay_ms = integerValue(value, 0, 3600 * 1000, "start_delay_ms");
      } else {
        failAt(attr.pos, "unknown command attribute '" + attr.text +
                             "' (exec, host, group, auto_respawn, stop_signal, "
                             "stop_time_allowed, start_delay_ms)");
      }
      expect(Tok::kEnd, "';' after the value of " + attr.text);
    }
    const Token close = expect(Tok::kClose, "an attribute or '}'");
    if (!has_exec || cmd.exec.find_first_not_of(" \t") == std::string::npos) {
      failAt(close.pos,
             "command " +
                 (cmd.name.empty() ? std::string("without a name") : "\"" + cmd.name + "\"") +
                 " has no exec");
    }
    if (cmd.name.empty()) cmd.name = cmd.exec;
    if (const CommandSpec* first = config_.findCommand(cmd.name)) {
      failAt(name_token.text.empty() ? cmd.pos : name_token.pos,
             "duplicate command name \"" + cmd.name + "\" (first at line " +
                 std::to_string(first->pos.line) + ")");
    }
    if (!cmd.group.empty()) addGroup(cmd.group);
    config_.commands.push_back(std::move(cmd));
  }

  void addGroup(const std::string& path) {
    // Every prefix is a group too ("a/b" implies "a").
    for (size_t slash = path.find('/'); slash != std::string::npos;
         slash = path.find('/', slash + 1)) {
      addGroup(path.substr(0, slash));
    }
    if (!config_.hasGroup(path)) config_.groups.push_back(path);
  }

  void parseGroup(const std::string& parent) {
    const Token name = expect(Tok::kString, "a group name in quotes");
    checkName(name, "group");
    const std::string path = parent.empty() ? name.text : parent + "/" + name.text;
    addGroup(path);
    expect(Tok::kOpen, "'{' after the group name");
    while (!peekIs(Tok::kClose)) {
      if (peekIs(Tok::kEof)) failExpected("'}' closing group \"" + path + "\"");
      const Token kw = expectWord({"cmd", "group"});
      if (kw.text == "cmd") {
        parseCommand(path);
      } else {
        parseGroup(path);
      }
    }
    take();
  }

  TargetKind parseTarget(ScriptAction* a) {
    const Token kind = expectWord({"cmd", "group", "everything"});
    if (kind.text == "everything") return TargetKind::kEverything;
    a->target = expectString("a " + kind.text + " name in quotes");
    return kind.text == "cmd" ? TargetKind::kCommand : TargetKind::kGroup;
  }

  WaitFor parseStatus() {
    const Token s = expect(Tok::kString, "\"running\" or \"stopped\"");
    if (s.text == "running") return WaitFor::kRunning;
    if (s.text == "stopped") return WaitFor::kStopped;
    failAt(s.pos, "expected \"running\" or \"stopped\", got \"" + s.text + "\"");
  }

  ScriptAction parseAction() {
    ScriptAction a;
    a.pos = next_.pos;
    const Token verb = expectWord({"start", "stop", "restart", "wait", "run_script"});
    if (verb.text == "start" || verb.text == "stop" || verb.text == "restart") {
      a.kind = verb.text == "start"  ? ScriptAction::Kind::kStart
               : verb.text == "stop" ? ScriptAction::Kind::kStop
                                     : ScriptAction::Kind::kRestart;
      a.target_kind = parseTarget(&a);
      if (peekIs(Tok::kIdentifier) && next_.text == "wait") {
        take();
        const SourcePos status_pos = next_.pos;
        a.wait = parseStatus();
        if (a.kind == ScriptAction::Kind::kStop && a.wait == WaitFor::kRunning) {
          failAt(status_pos, "a stop can only wait for \"stopped\"");
        }
      } else if (!peekIs(Tok::kEnd)) {
        failExpected("';' or wait");
      }
    } else if (verb.text == "wait") {
      const Token kind = expectWord({"ms", "cmd", "group"});
      if (kind.text == "ms") {
        a.kind = ScriptAction::Kind::kWaitMs;
        a.delay_ms = integerValue(expect(Tok::kInteger, "milliseconds"), 0,
                                  std::numeric_limits<int>::max(), "wait ms");
      } else {
        a.kind = ScriptAction::Kind::kWaitStatus;
        a.target_kind = kind.text == "cmd" ? TargetKind::kCommand : TargetKind::kGroup;
        a.target = expectString("a " + kind.text + " name in quotes");
        expectWord({"status"});
        a.wait = parseStatus();
      }
    } else {
      a.kind = ScriptAction::Kind::kRunScript;
      a.target = expectString("a script name in quotes");
    }
    expect(Tok::kEnd, "';'");
    return a;
  }

  void parseScript() {
    Script s;
    s.pos = next_.pos;
    const Token name = expect(Tok::kString, "a script name in quotes");
    s.name = name.text;
    if (s.name.empty()) failAt(name.pos, "empty script name");
    if (const Script* first = config_.findScript(s.name)) {
      failAt(name.pos, "duplicate script name \"" + s.name + "\" (first at line " +
                           std::to_string(first->pos.line) + ")");
    }
    expect(Tok::kOpen, "'{' after the script name");
    while (!peekIs(Tok::kClose)) {
      if (peekIs(Tok::kEof)) failExpected("'}' closing script \"" + s.name + "\"");
      s.actions.push_back(parseAction());
    }
    take();
    config_.scripts.push_back(std::move(s));
  }

  Tokenizer tokens_;
  Token next_;
  Config config_;
};

// Script actions may name commands, groups and scripts defined anywhere in the file, so they
// are checked once everything is read.
void checkReferences(Config* config) {
  for (Script& s : config->scripts) {
    for (ScriptAction& a : s.actions) {
      if (a.kind == ScriptAction::Kind::kWaitMs) continue;
      if (a.kind == ScriptAction::Kind::kRunScript) {
        if (!config->findScript(a.target)) {
          throw ParseFailure{a.pos,
                             "script \"" + s.name + "\" runs unknown script \"" + a.target + "\""};
        }
        continue;
      }
      if (a.target_kind == TargetKind::kCommand && !config->findCommand(a.target)) {
        throw ParseFailure{a.pos, "unknown command \"" + a.target + "\""};
      }
      if (a.target_kind == TargetKind::kGroup) {
        a.target = normalizeGroupPath(a.target);
        if (!config->hasGroup(a.target)) {
          throw ParseFailure{a.pos, "unknown group \"" + a.target + "\""};
        }
      }
    }
  }
  // run_script cycles would never end: depth-first search with colours.
  enum Colour { kWhite, kGrey, kBlack };
  std::vector<Colour> colour(config->scripts.size(), kWhite);
  auto index = [&](const std::string& name) {
    for (size_t i = 0; i < config->scripts.size(); ++i) {
      if (config->scripts[i].name == name) return i;
    }
    return config->scripts.size();
  };
  auto visit = [&](auto&& self, size_t i) -> void {
    colour[i] = kGrey;
    for (const ScriptAction& a : config->scripts[i].actions) {
      if (a.kind != ScriptAction::Kind::kRunScript) continue;
      const size_t j = index(a.target);
      if (colour[j] == kGrey) {
        throw ParseFailure{a.pos, "script \"" + config->scripts[i].name + "\" calls \"" + a.target +
                                      "\", which leads back to it"};
      }
      if (colour[j] == kWhite) self(self, j);
    }
    colour[i] = kBlack;
  };
  for (size_t i = 0; i < config->scripts.size(); ++i) {
    if (colour[i] == kWhite) visit(visit, i);
  }
}

}  // namespace

Expected<Config> parseConfig(std::string_view text, const std::string& source) {
  try {
    Config config = Parser(text).parse();
    checkReferences(&config);
    config.source = source;
    return config;
  } catch (const ParseFailure& f) {
    return makeError(source, ":", f.pos.line, ":", f.pos.column, ": ", f.message);
  }
}

Expected<Config> loadConfig(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return makeError(file.string(), ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return makeError(file.string(), ": read error");
  return parseConfig(text.str(), file.string());
}

}  // namespace evermap::deputy
