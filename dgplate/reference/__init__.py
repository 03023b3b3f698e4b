"""Published reference values and exact solutions that demos, tests and benchmarks compare against."""
