"""Sans-I/O JSON-RPC 2.0 layer: protocol (frames), contract (the OpenRPC document: params, results),
params (validated access), dispatch (method table).

Nothing is imported here: ``python -m robwot_sim`` reads ``protocol``'s limits before it starts the
labelling pool, and the contract (jsonschema) would delay that start. Import the submodules."""
