// The files a command reads, so that none of its outputs replaces one: `ibl sh env.hdr --out env.hdr`,
// `eval --in q.csv --out q.csv` and `repr export F --out F` destroyed their input and exited 0.
//
// While an InputGuard is open (the CLI opens one around every command), each reader notes the input
// it opens (note_input) by file identity - device and inode - so links, folders ("--out ." beside an
// input of the output's name) and other spellings resolve to the same file. An output that is a noted
// input is refused with an OutputError (exit status 2): by prepare_output, before any work, when the
// input was noted first (commands note their inputs as they check them); in any case by the commit,
// before anything is renamed. Without a guard (the library, tests) nothing is recorded.
#pragma once

#include <string>

namespace ms {

class InputGuard {
public:
    InputGuard();
    ~InputGuard();
    InputGuard(const InputGuard&) = delete;
    InputGuard& operator=(const InputGuard&) = delete;
};

// Records `path` (followed through links) as an input of the running command; nothing when no guard is
// open or the file does not exist.
void note_input(const std::string& path);

// Throws OutputError "cannot write NAMED: it is the input PATH ..." when the existing file `output`
// (followed through links) is a noted input.
void refuse_if_input(const std::string& output, const std::string& named);

}  // namespace ms
