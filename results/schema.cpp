// The schema text: results/schema.sql, compiled in by CMake (results/schema_sql.hpp.in).
#include "palplab/schema_sql.hpp"
#include "results/store.hpp"

namespace palplab::results {

std::string schema_sql() {
  return kSchemaSqlText;
}

}  // namespace palplab::results
