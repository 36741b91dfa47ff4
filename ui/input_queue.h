// Real input (keys, characters, mouse buttons, the wheel and pointer moves) kept in the order the window system
// delivered it and handed to Dear ImGui a step per frame (GL-free).
//
// Dear ImGui 1.86 reads keys and mouse buttons as levels once per frame (io.KeysDown, io.MouseDown) and the
// pointer where it is when the frame starts. Input that comes faster than frames (xdotool, a quick tap, a
// slow frame under load) was lost or misread: a key pressed and released between two frames was never seen
// down; a click's release was taken where the pointer was at the next frame, often already elsewhere, so the
// button under the click did not fire; a Ctrl+Shift+S whose Ctrl and Shift were let go before the S (xdotool
// does so, and people) became a plain S. Here every press is seen down for a frame of its own with the
// modifiers held at that press, its release in a later frame, and each click at the place it happened. The
// wheel too: the backend added each turn to the next frame at once, with the pointer where that frame's queued
// moves left it, so a turn over the 3D view followed by a move onto a photo (or a click queued before it)
// zoomed the photo, or came before the click; now a turn is seen where and when it happened.
#pragma once

#include <array>
#include <deque>
#include <vector>

namespace montage {

struct InputEvent {
  enum class Kind { Key, Char, Button, Move, Scroll };
  Kind kind = Kind::Move;
  int code = 0;           // Key: the key code (GLFW_KEY_*); Button: the mouse button; Char: the character
  bool down = false;      // Key and Button: pressed (true) or released
  bool modifier = false;  // Key: a Ctrl, Shift, Alt or Super key (its press or release does not end a step)
  int mods = 0;           // Key: the modifier flags held at the event (GLFW_MOD_*)
  double x = 0, y = 0;    // Move: where the pointer went; Scroll: the wheel's horizontal and vertical turn
};

// What one frame presents to ImGui.
struct InputFrame {
  std::array<bool, 512> keys{};   // keys down
  std::array<bool, 5> buttons{};  // mouse buttons down
  std::vector<unsigned> chars;    // characters typed, in order
  int pressMods = 0;              // the modifiers held at this frame's key press (0 without one)
  bool hasPointer = false;        // a move has been queued: (x, y) is the pointer's place after this frame's events
  double x = 0, y = 0;
  double wheelX = 0, wheelY = 0;  // the wheel's turns in this frame (not levels: zero in a frame without any)
  bool taken = false;             // events were taken for this frame
  bool presses = false;           // a key, character or button among them (its outcome is drawn in a frame after)
};

class RealInputQueue {
 public:
  void push(const InputEvent& event);
  bool pending() const { return !events_.empty(); }
  // The next frame's input: the queued events in order up to the first that must be seen in a frame of its
  // own: a key press (with the characters it typed), a mouse button's press or release, a run of wheel turns
  // with no other event between them, and never a press and release of the same key or button in one frame. Pointer
  // moves, modifier keys and releases of keys pressed in an earlier frame go along.
  InputFrame next();

 private:
  std::deque<InputEvent> events_;
  InputFrame state_;  // the levels and pointer as presented so far
};

}  // namespace montage
