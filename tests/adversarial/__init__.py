"""The adversarial suite (issue 15): inputs and events an unlucky operator produces, each with its
exact outcome.  The classes and the promises they check are listed in docs/reliability.md."""
