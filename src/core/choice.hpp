#pragma once
// Choices among a few named options (a scene's softening, contact activation, the backend):
// enums in the code, words in scene files, command lines and messages. Each enum lists its
// words once, in its own order, in a ChoiceNames specialisation beside it.
#include <array>
#include <cstddef>
#include <string>

namespace fdem {

/// ChoiceNames<E>::words: the word of each value of E, in the enum's order.
template <class E>
struct ChoiceNames;

/// The word for e.
template <class E>
const char* name_of(E e) {
  return ChoiceNames<E>::words[std::size_t(e)];
}

/// The value whose word is `word`; false (out unchanged) where none is.
template <class E>
bool choice_named(const std::string& word, E& out) {
  const auto& words = ChoiceNames<E>::words;
  for (std::size_t k = 0; k < words.size(); ++k)
    if (word == words[k]) {
      out = E(k);
      return true;
    }
  return false;
}

/// Every word of E, separated by `sep` ("adaptive | full | none").
template <class E>
std::string choice_list(const std::string& sep) {
  std::string list;
  for (const char* w : ChoiceNames<E>::words) list += (list.empty() ? "" : sep) + w;
  return list;
}

}  // namespace fdem
