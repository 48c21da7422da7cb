// DuckDB over saulctl's long CSV (decode --format long): per message and signal, the row count, the mean value and
// the unit, as JSON on stdout; the value column's type as DuckDB inferred it. tests/cli/long_csv.py compares them
// with its own figures. Runs from tests/npm so that node finds @duckdb/node-api in tests/npm/node_modules.
//   node tests/npm/long_csv_duckdb.mjs signals.csv
import { DuckDBInstance } from '@duckdb/node-api';

const path = process.argv[2];
const instance = await DuckDBInstance.create(':memory:');
const conn = await instance.connect();
const quoted = path.replaceAll("'", "''");
const reader = await conn.runAndReadAll(
  `select message, signal, count(*)::INTEGER as n, avg(value) as mean, coalesce(min(unit), '') as unit,
          typeof(any_value(value)) as value_type
   from read_csv_auto('${quoted}', header = true) group by all order by all`);
console.log(JSON.stringify(reader.getRowObjectsJson()));
