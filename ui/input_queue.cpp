#include "input_queue.h"

namespace montage {

void RealInputQueue::push(const InputEvent& event) {
  events_.push_back(event);
}

InputFrame RealInputQueue::next() {
  InputFrame& s = state_;
  s.chars.clear();
  s.pressMods = 0;
  s.taken = s.presses = false;
  s.wheelX = s.wheelY = 0;
  std::array<bool, 512> keyChanged{};
  while (!events_.empty()) {
    const InputEvent e = events_.front();
    bool last = false;  // this event is the last of the frame
    switch (e.kind) {
      case InputEvent::Kind::Move:
        s.hasPointer = true;
        s.x = e.x;
        s.y = e.y;
        break;
      case InputEvent::Kind::Char:
        s.chars.push_back(static_cast<unsigned>(e.code));
        s.presses = true;
        break;
      case InputEvent::Kind::Key:
        if (e.code < 0 || e.code >= static_cast<int>(s.keys.size()) || s.keys[e.code] == e.down) break;
        if (keyChanged[e.code]) return s;  // pressed and released in one frame: the second half in the next
        s.keys[e.code] = e.down;
        keyChanged[e.code] = true;
        s.presses = true;
        if (e.down && !e.modifier) {
          s.pressMods = e.mods;
          last = true;
        }
        break;
      case InputEvent::Kind::Scroll:
        // Turns in a row add up; the frame ends before whatever comes after them (a move away, a click).
        s.wheelX += e.x;
        s.wheelY += e.y;
        s.presses = true;
        last = events_.size() < 2 || events_[1].kind != InputEvent::Kind::Scroll;
        break;
      case InputEvent::Kind::Button:
        if (e.code < 0 || e.code >= static_cast<int>(s.buttons.size()) || s.buttons[e.code] == e.down) break;
        s.buttons[e.code] = e.down;
        s.presses = true;
        last = true;
        break;
    }
    s.taken = true;
    events_.pop_front();
    if (last) {
      // A key press brings the characters it typed (GLFW reports them right after it).
      while (e.kind == InputEvent::Kind::Key && !events_.empty() && events_.front().kind == InputEvent::Kind::Char) {
        s.chars.push_back(static_cast<unsigned>(events_.front().code));
        events_.pop_front();
      }
      break;
    }
  }
  return s;
}

}  // namespace montage
