// morse/core/options.hpp: the registry of the options morse reads, and the unknown-option check
// derived from it.
//
// Every option morse reads is registered where it is read, with its help text: the MorseOptions*
// wrappers below replace PETSc's PetscOptions* calls inside a PetscOptionsBegin/End block, take
// the block's prefix into account, register the full name and then call PETSc. Options read later
// by PETSc/SLEPc objects (an EPS, a SNES, a KSP and the objects below them) are not registered one
// by one: their solver's options prefix is (add_prefix), where the solver is given that prefix.
//
// check_unknown(comm, true), called by a command once it has read its own options and before any
// work, refuses every option given but not read that looks like a morse option: it shares its
// first word (the text up to the first '_') with a registered option, or is a few edits away from
// one, and is not under a registered solver prefix. check_unknown(comm, false), at the end of a
// run, refuses every option nobody used. Both name the closest registered option when it is close
// ("did you mean ...?"). PETSc's own global options (-help, -options_left, -log_*, -malloc_*,
// -info, ...) are never refused.
//
// The registry is per process and not thread-safe; every rank registers the same names, since
// every rank reads the same options.
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <cstddef>
#include <string>
#include <vector>

namespace morse::options {

/// Registers option `name` (with its leading '-' and its prefix, as given on the command line)
/// with its help text. Registering a name again with the same help text does nothing; with
/// another help text it is a programming error: recorded (see conflicts()), and an assertion in
/// debug builds. Not collective.
void add(const std::string& name, const std::string& help);
/// The same for a name as PETSc forms it inside a PetscOptionsBegin block: "-" + prefix +
/// name without its '-' (prefix may be null or empty). Not collective.
void add(const char* prefix, const char* name, const char* help);

/// The options-reading objects of a solver given an options prefix.
enum class Solver {
  Eigen,      ///< morse's eigen solvers (cb/eigen.hpp): SLEPc's eps_ st_ bv_ ds_ rg_, the inertia_
              ///< and block_ factorizations, eigen_solver, count_slicing, check_inertia
  Nonlinear,  ///< a SNES with its KSP, PC and MUMPS factor: snes_ ksp_ pc_ mat_mumps_
  Linear,     ///< a KSP with its PC and MUMPS factor: ksp_ pc_ mat_mumps_
};

/// Registers the options prefix of a solver (e.g. "cb_", Solver::Eigen: -cb_eps_tol,
/// -cb_st_mat_mumps_icntl_14, -cb_block_size, ... are options of inner objects, read when the
/// solver runs, and not refused by the early check). Not collective.
void add_prefix(const std::string& prefix, Solver kind);

/// Whether `name` (with or without its leading '-') is registered.
bool registered(const std::string& name);
/// The help text of a registered option ("" if it is not registered).
std::string help(const std::string& name);
/// Whether `name` (with or without its leading '-') is an option of a registered solver prefix.
bool inner(const std::string& name);
/// The registered names, sorted, with their leading '-'.
std::vector<std::string> names();
/// The names registered twice with different help texts (a programming error), with both texts.
std::vector<std::string> conflicts();
/// Forgets every registration: a command starts with an empty registry (app::run_command), so
/// that commands run one after the other in one process (tests) may give an option such as -out
/// their own help text.
void clear();

/// Optimal-string-alignment (Damerau-Levenshtein) distance: insertions, deletions,
/// substitutions and transpositions of adjacent characters each count 1.
std::size_t edit_distance(const std::string& a, const std::string& b);
/// The registered option nearest to `name` (with or without '-'), with its '-', if it is close
/// enough to be a misspelling of it (at most 1 edit for short names, 2 up to 10 characters,
/// 3 beyond); "" otherwise.
std::string closest(const std::string& name);
/// Whether an option not read by morse should be refused by the early check: `name` (with or
/// without '-') shares its first word with a registered option or is close to one (closest()), is
/// not under a registered solver prefix and is not one of PETSc's global options.
bool suspicious(const std::string& name);
/// Whether `name` is one of PETSc's global options (-help, -options_left, -log_*, -malloc_*,
/// -info, -options_file, ...), never refused.
bool petsc_global(const std::string& name);

/// The unknown-option check. early (after the command has read its own options, before any
/// work): refuses the options given but not read that suspicious() flags; final (end of the run):
/// refuses every option nobody used. Both refuse a registration conflict (conflicts(), a
/// programming error: "internal error: -x registered with two help texts ..."). The message names
/// each option (in alphabetical order) and, when one is close, the registered option it probably
/// meant: "unknown option(s): -casing_clearence (did you mean -casing_clearance?) (see -help)".
/// Collective on comm (every rank throws morse::Error).
void check_unknown(MPI_Comm comm, bool early);

/// The unknown-option check of the options under one prefix, once the solvers that read them are
/// set up (a long run's first step): every option given as -<prefix>... that nobody has read is
/// refused, naming it and `what` ("the fom solvers"), with the registered option it probably
/// meant when one is close. A misspelled inner-solver option (-fom_krylov_ksp_monitr) is so
/// refused before the run goes on instead of at its end. Collective (every rank throws).
void check_prefix_used(MPI_Comm comm, const std::string& prefix, const std::string& what);

/// The same list as a notice on rank 0, not an error, for solvers that read some options of their
/// prefix only later (SLEPc's -<prefix>eps_view..., the children of a sliced solve): "notice: not
/// (yet) read by <what>: -a (did you mean -b?); unknown options are refused at the end of the
/// run". Options whose name contains one of `later` are left out. Collective.
void notice_prefix_unused(MPI_Comm comm, const std::string& prefix, const std::string& what,
                          const std::vector<std::string>& later);

/// A comma-separated list option (e.g. -load_sets LE,tip; -sim_monitor LE) read under `prefix`
/// (may be null) and registered with its help text; at most 64 items. `list` is left unchanged if
/// the option is not given. Uses PetscOptionsBegin: returns a PETSc error code. Collective.
PetscErrorCode get_string_list(MPI_Comm comm, const char* name, const char* help, std::vector<std::string>* list,
                               const char* prefix = nullptr);

}  // namespace morse::options

namespace morse::options {

/// What the value of a numeric option must look like (check_value).
enum class Value {
  Int,            ///< an integer: optional sign and decimal digits, within PetscInt's range
  Real,           ///< a finite real number (strtod's syntax, the whole text)
  RealNonFinite,  ///< a real number, inf and nan allowed (an option that gives them a meaning)
  IntArray,       ///< comma-separated Int items, or ranges a-b (PETSc's syntax)
  RealArray,      ///< comma-separated Real items
};

/// Why `text`, the value given to option `name`, is not a `kind` value: "" if it is one.
/// ("-modes_nev 5abc: expected an integer"; "-modes_shift nan: expected a finite number").
std::string value_error(const std::string& name, const char* text, Value kind);

/// The magnitudes a material constant (Young's modulus, density) may have: its square must still
/// be a normal double, since the solvers square and multiply them (E = 1e-300 ends in a LAPACK
/// failure far away from the option).
inline constexpr double kMinMagnitude = 1e-150;
inline constexpr double kMaxMagnitude = 1e150;
/// "" if `value` is a positive number in [kMinMagnitude, kMaxMagnitude], else why not, naming
/// option `name`: "-material_E 1e-300 must be a positive number in [1e-150, 1e150]".
std::string magnitude_error(const std::string& name, double value);

/// Checks the value given to option `name` (with its '-', without the block's prefix) in the
/// options database of a PetscOptionsBegin block (prefix: the block's): throws morse::Error
/// (value_error) if it is given and is not a `kind` value, so that PETSc's lenient parsing
/// ("5abc" an error of its own, a 20-digit integer wrapped to -1, "nan", "default" = -2) never
/// reaches the code. Every rank reads the same options: every rank throws. Returns 0.
PetscErrorCode check_value(PetscOptions options, const char* prefix, const char* name, Value kind);

/// Rayleigh damping C = alpha M + beta K from option `name` given as alpha,beta (-fom_rayleigh,
/// -nlrom_rayleigh), read inside a PetscOptionsBegin block (PetscOptionsObject: the block's) and
/// registered with `help`. alpha and beta are left unchanged if the option is not given; *set says
/// whether it is. A given value that is not two numbers, or has one negative, is recorded in *error
/// (if still empty) naming the option ("-nlrom_rayleigh takes two values alpha,beta (got 1)"); a
/// non-finite one is refused by check_value (throws). Returns a PETSc error code. Collective.
PetscErrorCode get_rayleigh(PetscOptionItems* PetscOptionsObject, const char* name, const char* help, double* alpha,
                            double* beta, PetscBool* set, std::string* error);

}  // namespace morse::options

// Drop-in replacements for PETSc's option getters inside a PetscOptionsBegin/End block: same
// arguments; each registers the option (under the block's prefix) with its help text, then calls
// PETSc's. Use them as PETSc's: PetscCall(MorseOptionsReal("-x", "help", "", x, &x, nullptr)).
// The numeric ones first check the text given (check_value): integers strictly, reals finite
// (MorseOptionsRealNonFinite for an option that accepts inf or nan).
#define MORSE_OPTIONS_ADD_(opt, text) ::morse::options::add(PetscOptionsObject->prefix, (opt), (text))
#define MORSE_OPTIONS_CHECK_(opt, kind) \
  ::morse::options::check_value(PetscOptionsObject->options, PetscOptionsObject->prefix, (opt), kind)
#define MorseOptionsReal(opt, text, ...)                                                    \
  (MORSE_OPTIONS_ADD_(opt, text), MORSE_OPTIONS_CHECK_(opt, ::morse::options::Value::Real), \
   PetscOptionsReal(opt, text, __VA_ARGS__))
#define MorseOptionsRealNonFinite(opt, text, ...)                                                    \
  (MORSE_OPTIONS_ADD_(opt, text), MORSE_OPTIONS_CHECK_(opt, ::morse::options::Value::RealNonFinite), \
   PetscOptionsReal(opt, text, __VA_ARGS__))
#define MorseOptionsInt(opt, text, ...)                                                    \
  (MORSE_OPTIONS_ADD_(opt, text), MORSE_OPTIONS_CHECK_(opt, ::morse::options::Value::Int), \
   PetscOptionsInt(opt, text, __VA_ARGS__))
#define MorseOptionsBoundedInt(opt, text, ...)                                             \
  (MORSE_OPTIONS_ADD_(opt, text), MORSE_OPTIONS_CHECK_(opt, ::morse::options::Value::Int), \
   PetscOptionsBoundedInt(opt, text, __VA_ARGS__))
#define MorseOptionsRangeInt(opt, text, ...)                                               \
  (MORSE_OPTIONS_ADD_(opt, text), MORSE_OPTIONS_CHECK_(opt, ::morse::options::Value::Int), \
   PetscOptionsRangeInt(opt, text, __VA_ARGS__))
#define MorseOptionsBool(opt, text, ...) (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsBool(opt, text, __VA_ARGS__))
#define MorseOptionsString(opt, text, ...) (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsString(opt, text, __VA_ARGS__))
#define MorseOptionsEnum(opt, text, ...) (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsEnum(opt, text, __VA_ARGS__))
#define MorseOptionsEList(opt, text, ...) (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsEList(opt, text, __VA_ARGS__))
#define MorseOptionsName(opt, text, ...) (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsName(opt, text, __VA_ARGS__))
#define MorseOptionsRealArray(opt, text, ...)                                                    \
  (MORSE_OPTIONS_ADD_(opt, text), MORSE_OPTIONS_CHECK_(opt, ::morse::options::Value::RealArray), \
   PetscOptionsRealArray(opt, text, __VA_ARGS__))
#define MorseOptionsIntArray(opt, text, ...)                                                    \
  (MORSE_OPTIONS_ADD_(opt, text), MORSE_OPTIONS_CHECK_(opt, ::morse::options::Value::IntArray), \
   PetscOptionsIntArray(opt, text, __VA_ARGS__))
#define MorseOptionsBoolArray(opt, text, ...) \
  (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsBoolArray(opt, text, __VA_ARGS__))
#define MorseOptionsStringArray(opt, text, ...) \
  (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsStringArray(opt, text, __VA_ARGS__))
#define MorseOptionsEnumArray(opt, text, ...) \
  (MORSE_OPTIONS_ADD_(opt, text), PetscOptionsEnumArray(opt, text, __VA_ARGS__))
