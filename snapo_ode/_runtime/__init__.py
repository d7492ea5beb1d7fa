"""How a user runs the numerics: the command line's pieces (`options`, `exits`), results and
tables (`results`, `tables`), reports (`report_model`, `report_html`, `pdf`, `report`,
`provenance`), exported programs on disk (`exported`, `export_keys`, `export_helper`), and the
benches that time whole processes (`first_result`, `scaling`, `apart`, `accuracy`). The `snapo`
command itself is the public module `snapo_ode.cli`."""
