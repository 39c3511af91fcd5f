"""Models get a domain randomisation switch (DeepRacer's ENABLE_DOMAIN_RANDOMIZATION).

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-22
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # Models from before the switch train without randomisation, as they did.
    with op.batch_alter_table("models") as batch:
        batch.add_column(
            sa.Column("domain_randomization", sa.Boolean(), nullable=False, server_default=sa.false())
        )


def downgrade() -> None:
    with op.batch_alter_table("models") as batch:
        batch.drop_column("domain_randomization")
