// Editor scripts: a text file of UI actions (one per line) that drives the editor like a user does,
// through synthetic mouse and key events, for tests, benchmarks and README pictures. The format is
// documented in docs/editor.md. This parser has no GL, GLFW or ImGui.
//
//   # comment
//   wait_worker 120
//   click_vertex 1234
//   click_photo 0 412.5 300
//   key ctrl+z
//   save "/tmp/out project.json"
#pragma once

#include <string>
#include <vector>

namespace montage {

struct ScriptAction {
  int line = 0;  // 1-based line in the script file
  std::string verb;
  std::vector<std::string> args;

  // Argument i as a number; throws montage::Error "<file>:<line>: <verb>: argument i ..." when it is not one.
  double number(size_t i) const;
  int integer(size_t i) const;
  const std::string& text(size_t i) const { return args.at(i); }
  std::string where() const;  // "<file>:<line>: <verb>"
  std::string file;
};

struct ScriptVerb {
  const char* name;
  int minArgs, maxArgs;
  const char* usage;  // arguments, for docs and error messages
  const char* help;
};

// Every verb the editor understands, with its arguments (docs/editor.md lists the same).
const std::vector<ScriptVerb>& scriptVerbs();

// Parses a script: one action per line, arguments separated by blanks, "double quotes" around an
// argument with blanks (\" and \\ inside), '#' starts a comment. Unknown verbs and wrong argument
// counts are errors: montage::Error "<file>:<line>: <verb>: <reason>".
std::vector<ScriptAction> parseScript(const std::string& text, const std::string& file);
// Reads and parses a script file; throws montage::Error naming the file when it cannot be read.
std::vector<ScriptAction> loadScript(const std::string& path);

// A key combination such as "ctrl+shift+z", "delete", "enter", "f1".
struct KeyCombo {
  bool ctrl = false, shift = false, alt = false;
  std::string key;  // lower case: a letter or digit, or a name (delete, enter, escape, tab, space, f1..f12,
                    // left, right, up, down, backspace, home, end)
};
// Throws montage::Error naming the combination and the reason when it is not one.
KeyCombo parseKeyCombo(const std::string& text);

}  // namespace montage
