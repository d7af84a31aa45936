//! The tapeshape station program: tape link, session store, terminal interface and CLI.
